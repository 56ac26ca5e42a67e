"""Whole numeric tables at C speed (io.delimited.numeric_table, plain_head and plain_columns), the row-by-row reader
behind them, and the long-form writer (moved from tests/test_io.py: the same tests and assertions)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import denavit as dv
from denavit import sweeps as sw
from denavit.io import delimited as dl
from denavit.io import sweeps as swio

# -- whole numeric tables at C speed (io.delimited.numeric_table), the row-by-row reader behind it ----------


PLAIN_DECIMAL = r"[-+]?([0-9]{1,20}(\.[0-9]{0,20})?|\.[0-9]{1,20})([eE][-+]?[0-9]{1,3})?"


@settings(max_examples=300, deadline=None)
@given(st.lists(st.lists(st.from_regex(PLAIN_DECIMAL, fullmatch=True), min_size=3, max_size=3), min_size=1, max_size=5))
def test_numeric_table_takes_what_number_takes_with_the_same_values(cells):
    """Every cell the fast path takes, number() takes with the same double; a non-finite one sends the table
    back to the row-by-row reader (None)."""
    table = dl.numeric_table("\n".join(",".join(r) for r in cells).encode(), ",", 3)
    values = [[float(c) for c in r] for r in cells]
    if not np.isfinite(values).all():
        assert table is None
        return
    assert table is not None and table.tolist() == [[dl.number(c, "here", "x") for c in r] for r in cells]


@pytest.mark.parametrize(
    "body",
    [
        "1,2,3\nnan,2,3\n",
        "1,2,3\n1_0,2,3\n",
        "1,2,3\ninf,2,3\n",
        "1,2,3\n1e400,2,3\n",
        "1,2,3\n\n1,2,3\n",
        "1,2,3\n  \n1,2,3\n",
        "1,2,3\n1,2\n",
        "1,2,3,\n",
        '1,"2",3\n',
        "1,2,3 # note\n",
        "1,2,3\r4,5,6\n",
        "1,2,3\n\x0c4,5,6\n",
        "1,2,3\n\u00a04,5,6\n",
        "0x1p3,2,3\n",
        "1,,3\n",
        "1;2;3\n",
        "",
        "\n\n",
    ],
)
def test_numeric_table_leaves_anything_but_plain_rows_to_the_row_reader(body):
    assert dl.numeric_table(body.encode(), ",", 3) is None


def test_numeric_table_takes_crlf_blanks_around_cells_and_trailing_blank_lines():
    assert dl.numeric_table(b" 1 ,\t2,3\r\n4,5., .6e1\r\n\r\n\n", ",", 3).tolist() == [[1, 2, 3], [4, 5, 6]]


def _long_file(tmp_path, name, points=50, seed=3):
    kr5 = dv.load_robot("kr5")
    s = sw.simulate(
        kr5.model(),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
        points_per_sweep=points,
        noise=2e-5,
        noise_q=1e-5,
        seed=seed,
    )
    f = tmp_path / name
    f.write_text(swio.to_long_csv(s, "mm", "deg", "a comment\nof two lines"))
    return s, f


def test_the_long_csv_writer_round_trips_every_number(tmp_path):
    """The simulator's file gives back the very doubles it wrote, in the file's units (it wrote 10 digits)."""
    s, f = _long_file(tmp_path, "s.csv")
    back = swio.read_long_csv(f)
    for a, b in zip(s.sweeps, back.sweeps, strict=True):
        deg = np.pi / 180  # what the file holds is a.q / deg exactly: read back and scaled, a.q / deg * deg
        assert np.array_equal(b.points, a.points / 1e-3 * 1e-3) and np.array_equal(b.q, a.q / deg * deg)


def test_the_fast_and_the_row_by_row_reader_read_the_same(tmp_path):
    """A comment line at the end sends the file to the row-by-row reader: the same sweeps, homes and places;
    interleaved joints and a time column between the others read alike on both paths."""
    _, f = _long_file(tmp_path, "s.csv")
    lines = f.read_text().splitlines()
    head, rows = lines[:4], lines[4:]
    rows = rows[::2] + rows[1::2]  # joints interleaved: every sweep in two blocks
    head[3] = "time," + head[3]
    rows = [f"{k * 0.01:.2f},{r}" for k, r in enumerate(rows)]
    fast, slow = tmp_path / "fast.csv", tmp_path / "slow.csv"
    fast.write_text("\n".join(head + rows) + "\n")
    slow.write_text("\n".join(head + rows) + "\n# end of the recording\n")
    assert dl.numeric_table(fast.read_bytes().split(b"\n", 4)[4], ",", 11) is not None
    a, b = swio.read_long_csv(fast), swio.read_long_csv(slow)
    assert np.array_equal(a.home, b.home) and a.units == b.units
    for x, y in zip(a.sweeps, b.sweeps, strict=True):
        assert x.joint == y.joint and np.array_equal(x.points, y.points) and np.array_equal(x.q, y.q)
        assert list(x.where) == [w.replace("slow.csv", "fast.csv") for w in y.where]
    # (rows 0, 2, 4, ... of every sweep, then rows 1, 3, ...: sweep 1 at lines 5, 6, ... and 155, ...; sweep 2 from line
    # 30)
    assert (
        list(a.sweeps[0].where[:2]) == [f"{fast}:5", f"{fast}:6"]
        and a.sweeps[0].where[25] == f"{fast}:155"
        and a.sweeps[1].where[0] == f"{fast}:30"
    )


@pytest.mark.parametrize(
    "cell, match",
    [
        ("abc", r"column 'y' must be a number, got 'abc'"),
        ("nan", r"column 'y' must be finite, got 'nan'"),
        ("1,5", r"expected 10 values, got 11"),
    ],
)
def test_a_bad_cell_deep_in_a_long_file_names_its_line_and_column(tmp_path, cell, match):
    _, f = _long_file(tmp_path, "s.csv", points=2000)
    lines = f.read_text().splitlines()
    cells = lines[9000].split(",")
    cells[8] = cell
    lines[9000] = ",".join(cells)
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(dv.DenavitError, match=rf"s.csv:9001: {match}"):
        swio.read_long_csv(f)


def test_file_lines_are_a_sequence_of_places():
    w = swio.FileLines("f.csv", [3, 4, 7])
    assert (
        len(w) == 3 and w[0] == "f.csv:3" and w[-1] == "f.csv:7" and list(w[::-1]) == ["f.csv:7", "f.csv:4", "f.csv:3"]
    )
    assert list(w[np.array([2, 0])]) == ["f.csv:7", "f.csv:3"] and bool(w) and not swio.FileLines("f.csv", [])


def test_the_memory_mapped_pieces_read_what_the_row_by_row_reader_reads(tmp_path, monkeypatch):
    """A file beyond ARROW_BYTES is read from a memory map in pieces (made tiny here: many pieces, a row across
    each cut) by Arrow on threads: the same sweeps and places as the row-by-row reader; a bad cell deep in it, a
    lone carriage return or a blank line send it to that reader, which names the line."""
    monkeypatch.setattr(dl, "ARROW_BYTES", 1000)
    monkeypatch.setattr(dl, "PIECE_BYTES", 4096)
    _, f = _long_file(tmp_path, "s.csv", points=300)
    text = f.read_text()
    slow = tmp_path / "slow.csv"
    slow.write_text(text + "# the end\n")
    head = dl.plain_head(f, "sweep file")
    assert head is not None and dl.plain_columns(f, head, ",", 10, [[0], [7, 8, 9]]) is not None
    a, b = swio.read_long_csv(f), swio.read_long_csv(slow)
    assert np.array_equal(a.home, b.home)
    for x, y in zip(a.sweeps, b.sweeps, strict=True):
        assert np.array_equal(x.points, y.points) and np.array_equal(x.q, y.q)
        assert list(x.where) == [w.replace("slow.csv", "s.csv") for w in y.where]
    lines = text.splitlines()
    f.write_text("\n".join(lines[:1200] + [lines[1200][:-3] + "x1"] + lines[1201:]) + "\n")
    assert dl.plain_columns(f, head, ",", 10, [[0], [7, 8, 9]]) is None
    assert dl.plain_columns(f, head, ",", 10, [[0]]) is not None  # a column not asked for is split, not converted
    with pytest.raises(dv.DenavitError, match=r"s.csv:1201: column 'z' must be a number, got '"):
        swio.read_long_csv(f)
    f.write_text("\n".join(lines[:1000]) + "\r" + "\n".join(lines[1000:]) + "\n")
    assert dl.plain_columns(f, head, ",", 10, [[0]]) is None  # a lone \r: rows and lines would part
    f.write_text("\n".join(lines[:1000]) + "\n\n" + "\n".join(lines[1000:]) + "\n")
    assert dl.plain_columns(f, head, ",", 10, [[0]]) is None
    assert swio.read_long_csv(f).sweeps[5].where[-1] == f"{f}:{len(lines) + 1}"


def test_simulation_gives_simulate_s_sweeps_a_piece_at_a_time(tmp_path):
    """The pieces of sweeps.simulation, whatever their size, are simulate's sweeps (the same noise for the seed),
    and write_long_csv streaming them writes the bytes to_long_csv gives."""
    kr5 = dv.load_robot("kr5").model()
    kw = dict(
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
        points_per_sweep=23,
        noise=2e-5,
        noise_q=1e-5,
        seed=5,
        targets=[[0.05, 0.03, 0.1], [0.0, 0.0, 0.12]],
        poses=True,
        noise_rot=1e-4,
    )
    whole = sw.simulate(kr5, **kw)
    shape, pieces = sw.simulation(kr5, rows=5, **kw)
    pieces = list(pieces)
    assert [len(p.points) for p in pieces[:5]] == [5, 5, 5, 5, 3] and len(pieces) == 30
    for s in whole.sweeps:
        mine = [p for p in pieces if p.joint == s.joint]
        for name in ("points", "q", "targets", "rotations"):
            assert np.array_equal(getattr(s, name), np.concatenate([getattr(p, name) for p in mine])), name
    f = tmp_path / "w.csv"
    swio.write_long_csv(f, shape, "mm", "deg", "a comment", iter(pieces))
    assert f.read_text() == swio.to_long_csv(whole, "mm", "deg", "a comment")
    back = swio.read_long_csv(f)
    assert all(np.array_equal(a.q, b.q / (np.pi / 180) * (np.pi / 180)) for a, b in zip(back.sweeps, whole.sweeps))


def test_a_blank_line_after_the_header_keeps_the_line_numbers(tmp_path):
    """A blank line between the header and the first row is not a row: numpy's reader would skip it and the rows'
    line numbers would slip by one; the row-by-row reader reads such a file and names the right lines."""
    assert dl.numeric_table(b"\n1,2,3\n", ",", 3) is None and dl.numeric_table(b"\r\n1,2,3\n", ",", 3) is None
    _, f = _long_file(tmp_path, "s.csv", points=10)
    lines = f.read_text().splitlines()
    f.write_text("\n".join(lines[:4] + [""] + lines[4:]) + "\n")
    assert swio.read_long_csv(f).sweeps[0].where[0] == f"{f}:6"
