"""The ``bkabem`` command line: ``main`` builds the parser; one module per group of commands.

    main      -- the parser and the dispatch (``bkabem = bkabem_ros.cli.main:main``)
    base      -- the error contract: one line naming the argument, exit 2 for bad input
    core      -- excitation, spectrum, sweep, validate, demo
    synth     -- synth (profiles and scenarios)
    dataset   -- dataset
    ros       -- node and the ROS tools
    record, replay, demo
"""

__all__: list[str] = []
