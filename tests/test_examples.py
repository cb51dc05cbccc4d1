"""Tests for examples/: every command in every example's README runs as written (from a scratch folder)
and exits 0, and so does its Python; every JSON it verifies passes `foam-mj verify` and an independent MuJoCo
check; the tables that list the examples show their commands."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from foam_mj.cli import main

from test_bring_your_own_robot import _independent_clearance

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
READMES = sorted(EXAMPLES.glob("*/README.md"))


def _commands(readme: Path) -> list[str]:
    blocks = re.findall(r"```\n(.*?)```", readme.read_text(), flags=re.S)
    return [line.strip() for block in blocks for line in block.splitlines() if line.strip().startswith("foam-mj ")]


def test_every_example_has_a_readme_with_commands():
    """A robot's example plans and verifies; the study's sweeps and reports (examples/sweep had only comments)."""
    assert {p.parent.name for p in READMES} >= {"two_link_arm", "industrial_arm", "ortholeg5", "sweep"}
    for readme in READMES:
        pair = ("foam-mj sweep", "foam-mj report") if readme.parent.name == "sweep" else ("foam-mj plan", "foam-mj verify")
        for start in pair:
            assert any(c.startswith(start) for c in _commands(readme)), (readme, start)


@pytest.mark.slow
@pytest.mark.parametrize("readme", READMES, ids=[p.parent.name for p in READMES])
def test_the_readme_commands_run(readme, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for command in _commands(readme):
        argv = [a.replace("examples/", f"{EXAMPLES}/", 1) if a.startswith("examples/") else a for a in shlex.split(command)[1:]]
        if argv[0] == "plan":
            argv.append("--no-rrd")  # the recording is not what is tested here
        if argv[0] == "sweep":  # a few plans of the study in this process, as the first command does
            argv += ["--workers", "1", "--quiet"] + ([] if "--limit" in argv else ["--limit", "2"])
        assert main(argv) == 0, command
        if argv[0] == "verify":  # and a check that shares no code with foam-mj
            doc = json.loads((tmp_path / argv[1]).read_text())
            for name, entry in doc["paths"].items():
                assert _independent_clearance(doc["mjcf"], np.asarray(entry["qpos"])) >= doc["planner"]["delta"] - 1e-9, name
    for code in re.findall(r"```python\n(.*?)```", readme.read_text(), flags=re.S):  # the study's DuckDB query
        exec(compile(code, str(readme), "exec"), {})


def _table_commands(text: str) -> list[str]:
    """The `foam-mj plan ...` commands of a Markdown table's cells."""
    return re.findall(r"\| `(foam-mj plan [^`]*)` \|", text)


@pytest.mark.parametrize("index", ["examples/README.md", "README.md"])
def test_the_example_tables_show_commands_of_the_example_readmes(index):
    """examples/README.md and the README's Examples table name each example's command: each is (up to its --json)
    a command of the README in that example's folder, which test_the_readme_commands_run runs."""
    commands = [c for c in _table_commands((ROOT / index).read_text()) if "examples/" in c]
    assert len(commands) == 3, commands
    for command in commands:
        folder = re.search(r"examples/(\w+)/", command).group(1)
        own = [c.split(" --json")[0] for c in _commands(EXAMPLES / folder / "README.md")]
        assert command.split(" --json")[0] in own, (index, command)


def _section(text: str, heading: str) -> str:
    start = text.index(heading)
    return text[start:text.index("\n## ", start + len(heading))]


@pytest.mark.slow
def test_the_readmes_first_session_and_own_robot_run(tmp_path, monkeypatch):
    """The README's Using foam-mj: the first session's commands (all but `view`, which needs a display) exit 0 in
    a scratch folder, its Python reads the result they wrote, and its scenario TOML for a user's arm (the two-link
    arm of examples/ saved as my_arm.xml) plans, and its `bubble` check runs."""
    using = _section((ROOT / "README.md").read_text(), "## Using foam-mj")
    monkeypatch.chdir(tmp_path)
    session = [shlex.split(line.split("#")[0])[1:] for line in re.findall(r"```bash\n(.*?)```", using, flags=re.S)[0].splitlines()]
    assert [argv[0] for argv in session] == ["scenes", "plan", "verify", "export", "view"]
    for argv in session[:-1]:
        assert main(argv) == 0, argv
    assert (tmp_path / session[-1][1]).is_file()  # the recording view opens
    (code,) = re.findall(r"```python\n(.*?)```", using, flags=re.S)
    exec(compile(code, "README.md", "exec"), {})
    (toml,) = re.findall(r"```toml\n(.*?)```", using, flags=re.S)
    (tmp_path / "my_arm.toml").write_text(toml)
    (tmp_path / "my_arm.xml").write_text((EXAMPLES / "two_link_arm" / "arm.xml").read_text())
    check = shlex.split(re.search(r"`(foam-mj bubble --scene my_arm\.toml [^`]*)`", using).group(1))[1:]
    assert main(check) == 0
    assert main(["plan", "--scene", "my_arm.toml", "--no-rrd", "--json", "my_arm.json"]) == 0
    doc = json.loads((tmp_path / "my_arm.json").read_text())
    assert doc["planner"]["delta"] == 0.01 and doc["limits"]["torque"] == [20.0, 10.0]
    # The recording section's Python reads the first session's recording back: the torques the JSON holds.
    (code,) = re.findall(r"```python\n(.*?)```", _section((ROOT / "README.md").read_text(), "### The recording"), flags=re.S)
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    result = json.loads((tmp_path / session[1][-1]).read_text())
    assert "cspace/foam" in namespace["rows"] and len(namespace["tau"]) == len(result["paths"]["optimal"]["times"])
    assert max(row[0] for row in namespace["tau"]) == pytest.approx(result["paths"]["optimal"]["dynamics"]["peak_torque"][0])
    assert namespace["rgba"] & 0xFF == 255  # the optimal path's colour, opaque


@pytest.mark.slow
def test_the_readmes_python_api_runs():
    """The Planners section's Python (a problem, a planner, a result; a scenario from a dict; pipeline.run and what
    its outcome holds) runs as written, each block on its own as a reader pastes it into a fresh interpreter (the
    second once used load_scenario, imported only by the first: a NameError when pasted alone)."""
    planners = _section((ROOT / "README.md").read_text(), "## Planners")
    blocks = re.findall(r"```python\n(.*?)```", planners, flags=re.S)
    assert len(blocks) == 2
    seam, pipeline = {}, {}
    for code, namespace in zip(blocks, (seam, pipeline)):
        exec(compile(code, "README.md", "exec"), namespace)
    assert seam["result"].stats.outcome == "reached" and pipeline["po"].kinematic.min_clearance >= 0.005


def test_the_ortholeg5_command_line_scaling_is_the_small_subject_toml(tmp_path, monkeypatch):
    """examples/ortholeg5's "the same scaling from the command line" gives small_subject.toml's timed paths (its
    command once lacked the TOML's `--time-law own`: toppra's faster swing, other joint loads)."""
    monkeypatch.chdir(tmp_path)
    text = " ".join((EXAMPLES / "ortholeg5" / "README.md").read_text().split())
    command = re.search(r"The same scaling from the command line: `(foam-mj plan [^`]*)`", text).group(1)
    quick = ["--smoother", "none", "--no-rrd"]
    assert main([*shlex.split(command)[1:], *quick, "--json", "flags.json"]) == 0
    assert main(["plan", "--scene", str(EXAMPLES / "ortholeg5" / "small_subject.toml"), *quick, "--json", "toml.json"]) == 0
    flags, toml = (json.loads(Path(f).read_text()) for f in ("flags.json", "toml.json"))
    assert flags["time_law"] == toml["time_law"] == "own"
    a, b = flags["paths"]["centre"], toml["paths"]["centre"]
    assert a["times"] == b["times"] and a["dynamics"]["peak_torque"] == b["dynamics"]["peak_torque"]


def test_the_readmes_contents_line_lists_its_sections_in_order():
    """The Contents line names every `## ` section, in order and by the start of its heading; the items in
    parentheses after "Using foam-mj" are its bold paragraph leads, and those after "Command line" its `### `
    subsections and its tables (flags, exit codes) in order."""
    readme = (ROOT / "README.md").read_text()
    contents = " ".join(re.search(r"\nContents: (.*?)\n\n", readme, flags=re.S).group(1).split())
    items = re.findall(r"(?:^|; )([^;(]+?)(?: \(([^)]*)\))?(?=;|\. The papers|$)", contents)
    headings = re.findall(r"^## (.+)$", readme, flags=re.M)
    assert [h.split(":")[0].split(" (")[0] for h in headings] == [title.strip() for title, _ in items], (headings, items)
    subs = dict((title.strip(), [s.strip() for s in inside.split(",")]) for title, inside in items if inside)
    leads = [m.rstrip(".").lower() for m in re.findall(r"^\*\*([^*]+)\*\*", _section(readme, "## Using foam-mj"), flags=re.M)]
    assert [s.lower() for s in subs["Using foam-mj"]] == leads
    # Command line's anchors: its ### headings and its labels ("Flags:", "Exit codes (every command):", "Paths in ...:").
    anchors = [h.replace("`", "").lower() for h in re.findall(r"^(?:### (.+)|([A-Z][^|`\n]*:))$", _section(readme, "## Command line"),
                                                             flags=re.M) for h in h if h]
    at = 0
    for sub in subs["Command line"]:
        word = next(w for w in sub.replace("`", "").lower().split() if w != "the")
        at = next((i for i in range(at, len(anchors)) if word in anchors[i].split() or word in anchors[i].replace(":", " ").split()), None)
        assert at is not None, (sub, "is no heading or label of Command line after the item before it", anchors)
