"""catalogue: named mechanisms (TOML files with sources), number and type synthesis,
atlases (SQLite, HTML), distributed enumeration."""
