"""Optional extras (``tactile.errors``): a command that needs one that is missing says in one
line which extra and how to install it (exit 2), and keeps what it already wrote."""

import sys

import pytest

from tactile import errors as extras
from tactile.errors import MissingExtra

PLOT_HINT = "Plotting needs the 'plot' extra: pip install 'tactile-shape[plot]'"


def _block(monkeypatch, *names):
    for name in names:
        monkeypatch.setitem(sys.modules, name, None)  # import -> ImportError


def test_need_imports_what_is_there_and_names_the_extra_otherwise(monkeypatch):
    json, csv = extras.need("none", "Nothing", "json", "csv")
    assert json.dumps([1]) == "[1]" and csv.QUOTE_ALL is not None
    _block(monkeypatch, "no_such_module_here")
    with pytest.raises(MissingExtra) as err:
        extras.need("parquet", "Parquet export", "json", "no_such_module_here")
    assert str(err.value) == (
        "Parquet export needs the 'parquet' extra: pip install 'tactile-shape[parquet]'"
    )
    assert err.value.exit_code == 2


def test_pyplot_is_the_file_only_backend():
    pytest.importorskip("matplotlib")
    plt = extras.pyplot()
    assert plt.get_backend().lower() == "agg"


def test_plot_without_matplotlib_is_one_line(tmp_path, cli, monkeypatch):
    contacts = tmp_path / "c.csv"
    contacts.write_text("x,y,z,nx,ny,nz\n0,0,0,0,0,1\n")
    _block(monkeypatch, "matplotlib", "matplotlib.pyplot")
    code, out, err = cli("plot", contacts, "-o", tmp_path / "out")
    assert (code, out) == (2, "")
    assert err == f"tactile plot: error: {PLOT_HINT}\n"


def test_a_study_without_matplotlib_keeps_its_csv_and_says_why_no_figure(
    tmp_path, cli, monkeypatch
):
    _block(monkeypatch, "matplotlib", "matplotlib.pyplot")
    code, out, err = cli("study", "ep1-dtheta", "--out", tmp_path, "--trials", "1", "--quiet")
    assert code == 2
    assert err == f"tactile study: error: {PLOT_HINT}\n"
    assert (tmp_path / "ep1-dtheta.csv").stat().st_size > 0
    assert not list(tmp_path.glob("*.png"))
