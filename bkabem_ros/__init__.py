"""bkabem_ros: the command line, the ROS 2 node and its tools, recordings and the Rerun view.

    cli         -- the ``bkabem`` command: one module per group of commands, the error contract
    node        -- the vibration node (speed in; waveforms, spectra, fault frequencies out) and its tools
    messages    -- bkabem_msgs: arrays to messages and back, old message versions, fast CDR encoding
    recording   -- MCAP: record, replay, recover, integrity checks, the data-set sink
    viewer      -- Rerun: logging, the blueprint, the headless viewer's screenshots
    fleet       -- many namespaced machines per host, discovery across hosts
    ros_env     -- the ROS environment every process starts from (loopback by default)

Physics lives in bkabem_core; this package converts arrays to messages and back.
"""

__all__: list[str] = []
