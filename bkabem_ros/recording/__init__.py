"""Recordings: MCAP files of the ros2 profile, written, read, checked, recovered and replayed.

    record        -- ``bkabem record``: our topics into MCAP
    replay        -- publish a recording again, or convert it to Rerun
    mcap_io       -- the writer (``McapRecorder``, ``McapSink``) and ``recover``
    mcap_read     -- reading messages and summaries
    mcap_check    -- integrity: every chunk's CRC, damage
    dataset_sink  -- a data set's runs as MCAP files
"""

__all__: list[str] = []
