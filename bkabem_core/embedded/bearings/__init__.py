"""The bearing catalogue's data (``bkabem_core.model.catalogue``): ``deep_groove.csv``, ``clearance_iso5753.csv``,
``sources.csv``; README.md says where the numbers come from."""
__all__: list[str] = []
