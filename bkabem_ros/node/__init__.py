"""The vibration node: shaft speed in; acceleration, displacement, spectra and fault frequencies out.

    vibration_node -- ``VibrationNode``: parameters, the speed topic, the chunk timer, publication
    run            -- ``run``: one node until SIGINT/SIGTERM, its exit statistics line
    source         -- the machine behind the node: model, synthesiser, scenario driver
    band           -- the band-limit watch
    params         -- the node's parameters, their types and ranges
    speed          -- speed units, profiles, and the ``bkabem speed`` publisher
    echo           -- ``bkabem echo``
"""

__all__: list[str] = []
