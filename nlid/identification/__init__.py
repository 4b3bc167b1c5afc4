"""nlid.identify: any identifier run the same way, its provenance, and identifying again."""
