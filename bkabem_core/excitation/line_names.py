"""What a line is, in the words of a vibration analyst: ``BPFO``, ``3 BPFI - 1 f_r``, ``2 BSF + FTF``, ``1x``.

A line of a :class:`bkabem_core.excitation.lines.LineSet` has integer coefficients ``c = (a, b, s, l)`` on the base
phases (shaft, cage, spin, supply line); its frequency is ``a f_r + b FTF + s BSF + l f_line``. With ``z`` balls,
``BPFO = z FTF`` and ``BPFI = z (f_r - FTF)``, so the same line has several spellings; the name chosen is the one
an analyst reads off an envelope or a zoom spectrum:

- cage coefficient a multiple of ``z``, ``b = -m z`` with a shaft coefficient ``a > 0``: ``m BPFI`` and its
  sideband ``(a - m z) f_r`` (an inner-race defect turning with the shaft through the load zone);
- ``b = k z > 0``: ``k BPFO`` (an outer-race defect, or the ball passage of any bearing), with ``a f_r`` if any;
- otherwise ``b FTF`` (a ball defect's cage-rate sidebands, ``s BSF + b FTF``; the cage itself);
- spin coefficient ``s BSF`` (a ball defect strikes both races once per spin: ``2 BSF``);
- a line of only the shaft: ``1x``, ``2x``, ... (unbalance, misalignment); of only the supply: ``2 f_line``.

The family of a line (:func:`line_family`) is its leading term: the fault frequency it belongs to, for colours
and markers (``BPFO``, ``BPFI``, ``BSF``, ``FTF``, ``1x``, ``f_line``).
"""

from __future__ import annotations

__all__ = ["FAMILIES", "line_family", "line_label", "line_labels"]

#: Families of lines (the leading term of a name), in the order a figure's key lists them.
FAMILIES = ("BPFO", "BPFI", "BSF", "FTF", "1x", "f_line")


def _terms(coefficients, n_balls: int) -> list[tuple[int, str]]:
    """[(count, name)] of a line, the fault terms first, zero counts left out."""
    a, b, s, line = (int(v) for v in coefficients)
    z = int(n_balls)
    bpfi = bpfo = 0
    if z > 0 and b != 0 and b % z == 0:
        if b < 0 and a > 0:
            bpfi, a, b = -b // z, a + b, 0
        elif b > 0:
            bpfo, b = b // z, 0
    terms = [(bpfi, "BPFI"), (bpfo, "BPFO"), (s, "BSF"), (b, "FTF"), (a, "f_r"), (line, "f_line")]
    return [(n, name) for n, name in terms if n != 0]


def line_label(coefficients, n_balls: int) -> str:
    """The name of one line (module docstring), e.g. ``"BPFI - 1 f_r"`` for ``(z - 1, -z, 0, 0)``.

    Parameters
    ----------
    coefficients : sequence of 4 int
        ``(shaft, cage, spin, line)`` coefficients of the line.
    n_balls : int
        Number of balls ``z`` of the bearing the line belongs to.
    """
    terms = _terms(coefficients, n_balls)
    if not terms:
        return "DC"
    if len(terms) == 1 and terms[0][1] == "f_r":
        return f"{terms[0][0]}x"
    out = ""
    for i, (n, name) in enumerate(terms):
        count = abs(n)
        word = (name if count == 1 and name != "f_r" else f"{count} {name}")
        if i == 0:
            out = word if n > 0 else f"-{word}"
        else:
            out += (" + " if n > 0 else " - ") + word
    return out


def line_labels(coefficients, n_balls: int) -> list[str]:
    """:func:`line_label` of every row of ``coefficients`` (L, 4)."""
    return [line_label(c, n_balls) for c in coefficients]


def line_family(coefficients, n_balls: int) -> str:
    """The family of a line (:data:`FAMILIES`): the fault frequency its leading term names (``"1x"`` for shaft
    harmonics, ``"DC"`` for the static part)."""
    terms = _terms(coefficients, n_balls)
    if not terms:
        return "DC"
    name = terms[0][1]
    return "1x" if name == "f_r" else name
