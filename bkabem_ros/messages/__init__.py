"""bkabem_msgs in Python: arrays to messages and back, older message versions, direct CDR encoding.

    convert -- waveform, spectrum, fault-frequency and ground-truth messages
    compat  -- reading recordings of older bkabem_msgs versions
    cdr     -- CDR encoding of the waveform messages without rclpy
"""

__all__: list[str] = []
