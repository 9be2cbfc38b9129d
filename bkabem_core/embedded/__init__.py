"""What ships with bkabem: cases (``cases/``), scenarios (``scenarios/``) and data-set specs (``datasets/``),
each a TOML file read by name (``Case.load("motor_6010_inner")``).
"""

__all__: list[str] = []
