"""The Rerun view: logging the node's streams, the blueprint, and the headless viewer's screenshots.

    rerun_io     -- ``RerunLogger`` / ``RerunSink``
    rrd          -- the wheel's ``rerun`` executable, compacting a written ``.rrd``
    blueprint    -- the layout: tabs, views, units
    screenshots  -- the real viewer run headless: views, legends, screenshots (``make screenshots``)
"""

__all__: list[str] = []
