"""The identified model: the one result object, its plain data, tables, figures and reference."""
