"""Records and where they come from: Record and its rules, units, column maps, files, datasets, digests."""
