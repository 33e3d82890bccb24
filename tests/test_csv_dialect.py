"""The strict CSV dialect (``tactile.files.csv_dialect``): an unterminated quote, a second or
late ``# units:`` line, a column named twice and a number that is not an ASCII decimal
are each one line, exit 2, naming the file and line; through ``read_csv``, the streamed
contacts reader (both its parsers) and the calibration readers."""

import pytest

from tactile.calib import ati, files
from tactile.ep2.contacts_csv import read_contacts
from tactile.errors import InputError
from tactile.files import tabular
from tactile.files.tabular import read_csv

HEAD = "x,y,z,nx,ny,nz,patch\n"
ROWS = "".join(f"{i},{i % 3},{i * i % 5},0,0,1,a\n" for i in range(12))
REQ = ("x", "y", "z", "nx", "ny", "nz")
ODD_DIGITS = (
    "1_0",
    "\u0661\u0662",
    "\uff11\uff12",
    "\u0967",
)  # Arabic-Indic, fullwidth, Devanagari


def _readers(monkeypatch):
    """Every reader a contacts CSV goes through: the whole-table one and the streamed one
    with tiny blocks (the line-by-line parser) and large (the fast one where it can)."""

    def streamed(block):
        def read(path):
            monkeypatch.setattr(tabular, "BLOCK_BYTES", block)
            return read_contacts(path)

        return read

    return [lambda p: read_csv(p, REQ, ("patch",)), streamed(16), streamed(1 << 20)]


def _refused_everywhere(monkeypatch, path, match):
    for read in _readers(monkeypatch):
        with pytest.raises(InputError, match=match):
            read(path)


def test_an_unterminated_quote_is_refused_at_the_line_it_opens(tmp_path, monkeypatch):
    path = tmp_path / "c.csv"
    path.write_text(HEAD + ROWS + '1,2,3,0,0,1,"a\n' + ROWS)
    line = 14
    _refused_everywhere(monkeypatch, path, rf"c\.csv:{line}: a quote opened on this line is never")


def test_a_closed_quote_over_lines_is_still_a_cell(tmp_path, monkeypatch):
    path = tmp_path / "c.csv"
    path.write_text(HEAD + ROWS + '1,2,3,0,0,1,"a\nb"\n')
    for read in _readers(monkeypatch):
        read(path)


def test_text_after_a_closing_quote_is_refused(tmp_path, monkeypatch):
    path = tmp_path / "c.csv"
    path.write_text(HEAD + '1,2,3,0,0,1,"a"b\n' + ROWS)
    _refused_everywhere(monkeypatch, path, r"c\.csv:2: not valid CSV")


@pytest.mark.parametrize(
    "text, match",
    [
        ("# units: m\n# units: cm\n" + HEAD + ROWS, r"c\.csv:2: a second '# units:' line"),
        ("# units: m\n" + HEAD + "# units: cm\n" + ROWS, r"c\.csv:3: a '# units:' line after"),
        (HEAD + ROWS + "# Units: cm\n" + ROWS, r"a '# units:' line after the first row"),
    ],
    ids=["second", "after the header", "mid-file"],
)
def test_units_lines_are_one_and_before_the_header(tmp_path, monkeypatch, text, match):
    path = tmp_path / "c.csv"
    path.write_text(text)
    _refused_everywhere(monkeypatch, path, match)


def test_other_comments_may_come_anywhere(tmp_path, monkeypatch):
    path = tmp_path / "c.csv"
    path.write_text("# units: m\n# made by hand\n" + HEAD + ROWS + "# end: units were m\n")
    for read in _readers(monkeypatch):
        read(path)


def test_a_column_named_twice_is_refused(tmp_path, monkeypatch):
    path = tmp_path / "c.csv"
    path.write_text("x,y,z,nx,ny,nz,patch, x\n" + ROWS.replace(",a\n", ",a,5\n"))
    _refused_everywhere(monkeypatch, path, r"c\.csv:1: column 'x': named twice .*1 and 8")


@pytest.mark.parametrize("odd", ODD_DIGITS)
def test_numbers_are_ascii_decimals(tmp_path, monkeypatch, odd):
    path = tmp_path / "c.csv"
    path.write_text(HEAD + ROWS + f"1,{odd},3,0,0,1,a\n")
    _refused_everywhere(monkeypatch, path, r"c\.csv:14: column 'y': not a plain decimal number")


IDENTITY = [[float(i == j) for j in range(6)] for i in range(6)]


@pytest.mark.parametrize("odd", ODD_DIGITS)
def test_calibration_numbers_are_ascii_decimals(tmp_path, odd):
    rows = [",".join(repr(v) for v in r) for r in IDENTITY]
    rows[2] = rows[2].replace("1.0", odd)
    (tmp_path / "m.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(InputError, match=r"m\.csv:3: row 3 \(fz\), column 3 \(g2\): not a plain"):
        files.read(tmp_path / "m.csv")
    cal = ati.format_cal(IDENTITY, "FT7").replace('values="0.0 0.0 1.0', f'values="0.0 0.0 {odd}')
    (tmp_path / "m.cal").write_text(cal)
    with pytest.raises(InputError, match=r"m\.cal:6: column \d+: <UserAxis Name=\"Fz\">.*number 3"):
        files.read(tmp_path / "m.cal")


def test_calibration_csv_units_line_once_before_the_rows(tmp_path):
    rows = "\n".join(",".join(repr(v) for v in r) for r in IDENTITY) + "\n"
    for text, match in (
        ("# units: N, N-m\n# units: lbf, lbf-in\n" + rows, r"m\.csv:2: a second '# units:'"),
        (rows + "# units: N, N-m\n", r"m\.csv:7: a '# units:' line after the first row"),
    ):
        (tmp_path / "m.csv").write_text(text)
        with pytest.raises(InputError, match=match):
            files.read(tmp_path / "m.csv")


def test_ep2_analyze_of_an_unterminated_quote_is_exit_2_not_one_point(tmp_path, cli):
    path = tmp_path / "c.csv"
    path.write_text(HEAD + '0,0,0,0,0,1,"a\n' + ROWS)
    code, _, err = cli("ep2", "analyze", path)
    assert code == 2 and err.count("\n") == 1 and f"{path}:2: a quote opened" in err
