"""The embedded scenarios: machine and fleet scenarios (``Scenario.load(name)``)."""
__all__: list[str] = []
