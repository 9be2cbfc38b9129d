"""The embedded data-set specs (``DatasetSpec.load(name)``)."""
