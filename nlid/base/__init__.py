"""What every package stands on: frozen mappings, JSON values, numerical warnings, text, argument rules."""
