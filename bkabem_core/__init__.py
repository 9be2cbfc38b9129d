"""bkabem_core: the BKA-BEM vibration twin of a rotating machine on deep-groove ball bearings, as a library.

The packages follow the pipeline, each standing on the ones before it::

    bearing     the deep-groove ball bearing: geometry, kinematics, Hertz contact, defect kinds, contact forces
    model       the machine described: the case (a TOML file, validated), the bearing catalogue, plausibility
                bounds, the shared vocabulary
    excitation  each bearing's quasi-static excitation as lines; the machine baseline (unbalance, ...)
    fe          the finite-element rotor-bearing-housing model, the machine, its modal form and solvers
    solve       the BKA-BEM harmonic solve at any speed, and the improved method (time-varying stiffness)
    reference   the time-domain reference (TDSM), its periodic steady state, validation against it
    synth       waveforms: speed profiles, line sets in the angle domain, slip, noise, sensors, features
    scenario    machines over time: defects that appear and grow, speed and load profiles, fleets
    dataset     labelled data sets: specs, runs rendered to Parquet, local or Dask engines
    analysis    signal analysis as a monitoring pipeline reads it (envelope, ISO velocity), figures
    kernels     the C kernels of the solvers and the synthesiser
    embedded    the cases, scenarios and data-set specs shipped with bkabem

(``PIPELINE``: the packages from ``bearing`` to ``analysis`` in that order.)

The names most users need::

    Case            -- a validated machine case (model)
    Machine         -- the case's rotor, bearings and housings at their operating points (fe)
    BkaBem          -- the BKA-BEM model of a case: spectra at any shaft speed (solve)
    HillCorrection  -- the improved method (solve)
    Synthesizer     -- speed-driven sensor waveforms, chunk by chunk (synth)
    Scenario        -- a machine over scenario time (scenario)
    ScenarioRun     -- a scenario rendered offline with its ground truth (scenario)
    DatasetSpec     -- a data-set spec (dataset)
    render_dataset  -- render a data set (dataset)

bkabem_core is plain numpy/scipy (with small C kernels built at install time); it never imports ROS.
"""

from bkabem_core._face import lazy_face

#: The packages in the pipeline's order: each imports only the ones before it (``kernels`` serves ``synth``;
#: ``embedded`` is data every package may read).
PIPELINE = ("bearing", "model", "excitation", "fe", "solve", "reference", "synth", "scenario", "dataset", "analysis")

__all__ = ["PIPELINE", "Case", "Machine", "BkaBem", "HillCorrection", "Synthesizer", "Scenario", "ScenarioRun",
           "DatasetSpec", "render_dataset"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Case": "model.case",
    "Machine": "fe.machine",
    "BkaBem": "solve.harmonic",
    "HillCorrection": "solve.improved",
    "Synthesizer": "synth.synthesizer",
    "Scenario": "scenario.timeline",
    "ScenarioRun": "scenario.run",
    "DatasetSpec": "dataset.spec",
    "render_dataset": "dataset.engine",
})
