"""The embedded data-set specs (``DatasetSpec.load(name)``)."""
__all__: list[str] = []
