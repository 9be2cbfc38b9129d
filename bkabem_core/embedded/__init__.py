"""What ships with bkabem: cases (``cases/``), scenarios (``scenarios/``) and data-set specs (``datasets/``),
each a TOML file read by name (``Case.load("motor_6010_inner")``).

Listing (module ``listing``)
============================
    embedded_files        -- every embedded file with its one-line description (``bkabem list``)
"""

from bkabem_core._face import lazy_face

__all__ = ["embedded_files"]

__getattr__, __dir__ = lazy_face(__name__, {
    "embedded_files": "listing",
})
