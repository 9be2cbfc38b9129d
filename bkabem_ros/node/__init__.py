"""The vibration node: shaft speed in; acceleration, displacement, spectra and fault frequencies out.

    vibration_node -- ``VibrationNode``: parameters, the speed topic, live changes, the stream's start, sinks, stats
    stream         -- ``ChunkStream``: the publishers, the sample clock, chunks made one ahead and published when due
    declare        -- declaring the parameters: descriptors, the overrides checked at start
    run            -- ``run``: one node until SIGINT/SIGTERM, its exit statistics line
    source         -- the machine behind the node: model, synthesiser, scenario driver
    band           -- the band-limit watch
    params         -- the node's parameters, their types and ranges
    speed          -- speed units, profiles, the ``bkabem speed`` publisher, the speed topic's type watch
    echo           -- ``bkabem echo``
"""

__all__: list[str] = []
