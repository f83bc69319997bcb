"""docs/python.md's examples run and print what the page shows (Python's doctest), in a
scratch folder holding the shipped scenes and data, as a user's checkout would."""

import doctest


def test_the_python_page_runs_as_written(root, tmp_path, monkeypatch):
    for shipped in ["scenes", "data"]:
        (tmp_path / shipped).symlink_to(root / shipped)
    monkeypatch.chdir(tmp_path)
    result = doctest.testfile(
        str(root / "docs" / "python.md"),
        module_relative=False,
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
        raise_on_error=False,
        verbose=False,
    )
    assert result.attempted > 15, result
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples of docs/python.md failed (printed above)"
    assert (tmp_path / "runs" / "sweep_on_dask" / "results.csv").exists()
