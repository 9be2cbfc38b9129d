"""The Rerun view: logging the node's streams, the blueprint, and the headless viewer's screenshots.

    rerun_io        -- ``RerunLogger`` / ``RerunSink``
    rerun_rows      -- ``RecordingRows``: the recording's time line, batched rows, bar charts (the logger's base)
    rerun_condition -- ``ConditionPanels``: each bearing's condition window, ISO velocity, envelope, health panel
    rrd             -- the wheel's ``rerun`` executable, compacting a written ``.rrd``
    blueprint       -- the layout: tabs, views, units
    screenshots     -- the real viewer run headless: views, legends, screenshots (``make screenshots``)
"""

__all__: list[str] = []
