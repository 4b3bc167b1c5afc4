"""Between nlid and its identifiers: Identifier, Option, Estimate and its check, hooks, registry."""
