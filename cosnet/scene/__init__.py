"""Scene files (TOML): the loader, the ready cases and the generated scene reference."""
