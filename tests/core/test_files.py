"""The core's files (flexmbd/core/files.py) and places (flexmbd/core/resources.py) on their own:
strict JSON, a file replaced whole, files and folders swapped together or not at all, an unusable
location as one line naming it. The signals around them are exercised end to end in
tests/cli/test_faults.py."""

import errno
import json
import os

import numpy as np
import pytest

from flexmbd.core import errors, files, resources

pytestmark = pytest.mark.kernel_free


def test_json_text_is_strict_json_with_numpy_values_and_null_for_what_is_not_finite():
    text = files.json_text({"a": np.float64(1.5), "b": np.array([1, 2]), "c": float("nan"), "d": -np.inf,
                            "e": (np.int64(3), None), "f": object.__new__(type("Odd", (), {"__str__": lambda s: "odd"}))})
    assert json.loads(text) == {"a": 1.5, "b": [1, 2], "c": None, "d": None, "e": [3, None], "f": "odd"}
    assert "NaN" not in text and "Infinity" not in text


def test_atomic_write_replaces_a_file_whole_and_leaves_nothing_beside_it(tmp_path):
    path = tmp_path / "sub" / "page.txt"
    files.atomic_write(path, "old")
    files.atomic_write(path, b"new")
    assert path.read_text() == "new"
    assert sorted(p.name for p in path.parent.iterdir()) == ["page.txt"]


def test_swap_puts_a_file_and_a_folder_in_place_together(tmp_path):
    (tmp_path / "index.html").write_text("old index")
    (tmp_path / "case").mkdir()
    (tmp_path / "case" / "page.html").write_text("old page")
    staged = tmp_path / ".staged"
    staged.mkdir()
    (staged / "page.html").write_text("new page")
    with files.temporary(tmp_path / "index.html", "new index") as tmp:
        files.swap([(staged, tmp_path / "case"), (tmp, tmp_path / "index.html")])
    assert (tmp_path / "index.html").read_text() == "new index"
    assert (tmp_path / "case" / "page.html").read_text() == "new page"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case", "index.html"]       # nothing kept aside


def test_swap_refuses_a_file_where_a_folder_is_and_changes_nothing(tmp_path):
    (tmp_path / "case").mkdir()
    with files.temporary(tmp_path / "case", "a file") as tmp:
        with pytest.raises(errors.InputError, match=r"case: a folder is there, not a file"):
            files.swap([(tmp, tmp_path / "case")])
    assert (tmp_path / "case").is_dir() and sorted(p.name for p in tmp_path.iterdir()) == ["case"]


def test_an_unusable_location_is_one_line_naming_it(tmp_path):
    (tmp_path / "taken").write_text("a file")
    with pytest.raises(errors.InputError, match=r"taken: --out: a file is there, not a folder"):
        files.writable_dir(tmp_path / "taken", "--out")
    with pytest.raises(errors.InputError, match=r"lies under .*taken, which is a file"):
        files.writable_dir(tmp_path / "taken" / "below")
    e = files.unusable(tmp_path / "x", OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)), "writing")
    assert str(e) == f"{tmp_path / 'x'}: writing: no space left on the device" and "\n" not in str(e)


def test_the_shipped_cases_and_baselines_are_found_where_the_package_is():
    assert (resources.CASES / "pendulum.toml").is_file()
    assert resources.BASELINES.is_dir()
    assert resources.CHECKOUT is None or (resources.CHECKOUT / "pyproject.toml").is_file()
