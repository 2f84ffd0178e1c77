"""Scene files (TOML, one per scene in this folder) and their loader; schema in docs/scenes.md."""
