"""Fleets: many namespaced machines on one host, several hosts forming one plant.

    launcher   -- ``bkabem fleet``
    plan       -- which machine runs which case or scenario
    discovery  -- ``bkabem discovery-server``
"""

__all__: list[str] = []
