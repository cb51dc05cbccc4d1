"""foam_mj.results: writing and reading a result from Python."""

from __future__ import annotations

import pytest

from foam_mj.results import write_outcome


def test_write_outcome_names_a_path_that_is_not_one(tmp_path):
    # write_outcome(outcome, path), the arguments swapped, failed inside pathlib ("expected str, bytes or os.PathLike").
    with pytest.raises(TypeError, match=r"write_outcome\(path, outcome\): `path` must be a file path, got object"):
        write_outcome(object(), tmp_path / "out.json")
    assert list(tmp_path.iterdir()) == []
