"""The embedded cases: one TOML file per machine (``Case.load(name)``)."""
__all__: list[str] = []
