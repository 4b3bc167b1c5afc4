"""Signals of a record: derivatives, the zero-phase filters, the noise floor and the default cut-off, and the
glitches no model fits (clipped channels, isolated spikes)."""
