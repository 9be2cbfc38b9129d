"""The embedded scenarios: machine and fleet scenarios (``Scenario.load(name)``)."""
