"""Signals of a record: derivatives, the zero-phase filters, the noise floor and the default cut-off, and
clipped channels."""
