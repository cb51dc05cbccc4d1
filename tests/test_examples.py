"""Tests for examples/: every command in every example's README runs as written (from a scratch folder)
and exits 0; every JSON it writes passes an independent MuJoCo check (and `foam-mj verify` when present)."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest

from foam_mj.cli import build_parser, main

from test_bring_your_own_robot import _independent_clearance

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
READMES = sorted(EXAMPLES.glob("*/README.md"))


def _commands(readme: Path) -> list[str]:
    blocks = re.findall(r"```\n(.*?)```", readme.read_text(), flags=re.S)
    return [line.strip() for block in blocks for line in block.splitlines() if line.strip().startswith("foam-mj ")]


def _has_command(name: str) -> bool:
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return name in sub.choices


def test_every_example_has_a_readme_with_commands():
    assert {p.parent.name for p in READMES} >= {"two_link_arm", "industrial_arm", "ortholeg5"}
    for readme in READMES:
        assert any(c.startswith("foam-mj plan") for c in _commands(readme)), readme
        assert any(c.startswith("foam-mj verify") for c in _commands(readme)), readme


@pytest.mark.slow
@pytest.mark.parametrize("readme", READMES, ids=[p.parent.name for p in READMES])
def test_the_readme_commands_run(readme, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for command in _commands(readme):
        argv = [a.replace("examples/", f"{EXAMPLES}/", 1) if a.startswith("examples/") else a for a in shlex.split(command)[1:]]
        if argv[0] == "plan":
            argv.append("--no-rrd")  # the recording is not what is tested here
        if argv[0] == "verify" and not _has_command("verify"):
            doc = json.loads((tmp_path / argv[1]).read_text())
            for name, entry in doc["paths"].items():
                import numpy as np

                assert _independent_clearance(doc["mjcf"], np.asarray(entry["qpos"])) >= doc["planner"]["delta"] - 1e-9, name
            continue
        assert main(argv) == 0, command
