"""Everything that decides: satisfaction, actions, planning, FTM selection, the Alloy bridge, the CLI."""
