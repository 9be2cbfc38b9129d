"""Localised defects of a ball bearing: one module per kind, one protocol, one registry.

A kind (a pit in the outer race, the inner race, a ball) is one module implementing :class:`DefectKind`; the
registry finds the modules, so adding a kind is adding its module (and its tests).

The description and the drops (module ``base``)
===============================================
    Dent             -- a localised defect (dent, pit, spall): kind, size, angle, edge profile
    DefectSet        -- the defects of one bearing: the drop every ball feels
    DefectProfile    -- one defect with its bearing's geometry

The protocol (module ``protocol``)
==================================
    DefectKind       -- one kind: drop profile, phases, torus, fault frequency, words, file keys
    RaceDefect       -- the part shared by pits in a race
    DefectKey        -- a key of a [[defects]] table that only some kinds have
    TorusGrid        -- the sampled 2-torus of a moving kind's own angles

The registry (module ``registry``)
==================================
    KINDS            -- the names of the kinds, in listing order
    kind             -- the kind of a name
    kinds            -- every kind
    find             -- the kind of a name, or None

The kinds: one module each, reached through the registry (``outer_race``: fixed in space, m BPFO;
``inner_race``: turns with the shaft, m BPFI +- n f_r; ``ball``: spins with its ball, m BSF + n FTF, strikes at
2 x BSF).

Shared geometry (module ``profiles``)
=====================================
    ContactGeometry  -- what a kind knows of its bearing: race and ball radii, contact radii, balls
    EDGE_PROFILES    -- ``"ball"`` (ball over the sharp edges) or ``"cubic"`` (STEP edges)
    SHAPES           -- ``"slot"`` (across the ball track) or ``"round_pit"`` (bridged by the contact)
    outer_race_drop_m, inner_race_drop_m, bridged_drop_m, step_cubic, wrap_to_pi

A round pit, in any kind (module ``round_pit``)
===============================================
    PitContact       -- a round pit at one contact: its bridged drop profile, Hertz share, rigid drop
    PitProfile       -- the drop a ball feels over the arc from the pit's centre
"""

from bkabem_core._face import lazy_face

__all__ = ["Dent", "DefectSet", "DefectProfile", "DefectKind", "RaceDefect", "DefectKey", "TorusGrid", "KINDS", "kind", "kinds", "find", "ContactGeometry", "EDGE_PROFILES", "SHAPES", "PitContact", "PitProfile", "outer_race_drop_m", "inner_race_drop_m", "bridged_drop_m", "step_cubic", "wrap_to_pi"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Dent": "base",
    "DefectSet": "base",
    "DefectProfile": "base",
    "DefectKind": "protocol",
    "RaceDefect": "protocol",
    "DefectKey": "protocol",
    "TorusGrid": "protocol",
    "KINDS": "registry",
    "kind": "registry",
    "kinds": "registry",
    "find": "registry",
    "ContactGeometry": "profiles",
    "EDGE_PROFILES": "profiles",
    "SHAPES": "profiles",
    "PitContact": "round_pit",
    "PitProfile": "round_pit",
    "outer_race_drop_m": "profiles",
    "inner_race_drop_m": "profiles",
    "bridged_drop_m": "profiles",
    "step_cubic": "profiles",
    "wrap_to_pi": "profiles",
})
