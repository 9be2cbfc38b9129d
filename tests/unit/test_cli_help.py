"""A way in: ``bkabem list``, the top-level help's "start here", help text for every option, one noise unit."""

from __future__ import annotations

import json
import tomllib
from importlib import resources

import pytest

from bkabem_ros.cli.main import build_parser, main


def _subparsers():
    return build_parser()._subparsers._group_actions[0].choices


def _embedded() -> dict[str, dict[str, str]]:
    """kind -> {name: description}, read from the package's TOML files here."""
    out = {}
    for kind, tables in (("cases", ("case",)), ("scenarios", ("scenario", "fleet")), ("datasets", ("dataset",))):
        folder = resources.files("bkabem_core.embedded").joinpath(kind)
        out[kind] = {}
        for f in folder.iterdir():
            if f.name.endswith(".toml"):
                raw = tomllib.loads(f.read_text())
                table = next(t for t in tables if t in raw)
                out[kind][f.name[:-5]] = " ".join(raw[table]["description"].split())
    return out


def test_list_names_every_embedded_case_scenario_and_spec_with_one_line(capsys):
    want = _embedded()
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for kind, entries in want.items():
        assert out.count(f"{kind}: ") == 1
        for name, text in entries.items():
            (line,) = [ln for ln in out.splitlines() if ln.split()[:1] == [name]]
            assert text in line
    assert main(["list", "scenarios", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert {e["name"]: e["description"] for e in got} == want["scenarios"]
    with pytest.raises(SystemExit) as exc:
        main(["list", "recipes"])
    assert exc.value.code == 2 and "KIND must be one of" in capsys.readouterr().err


def test_top_level_help_says_where_to_start(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    start = out[out.index("start here:"):]
    assert "bkabem list" in start and "bkabem demo --no-ros" in start and "COMMAND --help" in start


def test_every_option_of_every_command_has_help_and_no_source_path():
    missing, sources = [], []
    for name, sp in _subparsers().items():
        if ".py" in (sp.description or ""):
            sources.append((name, "description"))
        for a in sp._actions:
            if a.dest == "help" or a.help == "==SUPPRESS==":
                continue
            if not (a.help or "").strip():
                missing.append((name, a.option_strings or a.dest))
            elif ".py" in a.help and "docs" not in a.help:
                sources.append((name, a.option_strings))
    assert missing == [] and sources == []


def test_noise_is_a_density_everywhere():
    """synth --noise-acc, a data set's noise_acc and the node's noise_acc: one quantity, one unit; the node's RMS
    parameters of earlier versions stay, marked deprecated."""
    from bkabem_ros.node.params import DEPRECATED_NOISE, PARAMETER_SPECS

    subs = _subparsers()
    unit = "m/s^2/sqrt(Hz)"
    synth = {a.option_strings[0]: a.help for a in subs["synth"]._actions if a.option_strings}
    node = {a.option_strings[0]: a.help for a in subs["node"]._actions if a.option_strings}
    assert unit in synth["--noise-acc"] and unit in node["--noise-acc"]
    assert PARAMETER_SPECS["noise_acc"].unit == unit and PARAMETER_SPECS["noise_disp"].unit == "m/sqrt(Hz)"
    assert PARAMETER_SPECS["noise_acc"].live and PARAMETER_SPECS["noise_disp"].live
    for old, new in DEPRECATED_NOISE.items():
        assert "deprecated" in PARAMETER_SPECS[old].description and new in PARAMETER_SPECS[old].description
    from pathlib import Path

    docs = Path(__file__).resolve().parents[2] / "docs" / "datasets.md"
    assert "| `noise_acc` | m/s^2/sqrt(Hz) |" in docs.read_text()
    from bkabem_ros.cli.ros import _overrides

    args = subs["node"].parse_args(["--noise-acc", "1e-3", "--noise-disp", "2e-9"])
    assert _overrides(args)["noise_acc"] == 1e-3 and _overrides(args)["noise_disp"] == 2e-9
