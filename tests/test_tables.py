import pytest

from bayescal.errors import InputError
from bayescal.tables import read_table

COLUMNS = {"q2_deg": "number", "marker": "text", "x_mm": "number"}


def write(tmp_path, text):
    path = tmp_path / "points.csv"
    path.write_text(text)
    return path


def test_reads_values_indexed_by_file_line(tmp_path):
    path = write(tmp_path, "# source: a comment\nq2_deg,marker,x_mm,extra\n\n-30,P1,1.5,ignored\n-60,P01,-2,x\n")
    frame = read_table(path, COLUMNS)
    assert list(frame.index) == [4, 5]
    assert list(frame.columns) == ["q2_deg", "marker", "x_mm"]
    assert frame.loc[5, "x_mm"] == -2.0
    assert frame.attrs["source"] == str(path)


def test_optional_column_is_read_when_present(tmp_path):
    path = write(tmp_path, "q2_deg,marker,x_mm,z_mm\n0,P1,1,2\n")
    assert read_table(path, COLUMNS, optional={"z_mm": "number"}).loc[2, "z_mm"] == 2.0
    path = write(tmp_path, "q2_deg,marker,x_mm\n0,P1,1\n")
    assert "z_mm" not in read_table(path, COLUMNS, optional={"z_mm": "number"})


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("q2_deg,marker\n0,P1\n", "missing column 'x_mm'"),
        ("q2_deg,marker,x_mm\n0,P1,abc\n", "points.csv:2, column 'x_mm': expected a number in mm, got 'abc'"),
        ("q2_deg,marker,x_mm\n0,P1,nan\n", "points.csv:2, column 'x_mm': expected a number in mm, got 'nan'"),
        ("q2_deg,marker,x_mm\n0,P1,\n", "points.csv:2, column 'x_mm': missing value"),
        ("q2_deg,marker,x_mm\n0,P1\n", "points.csv:2: expected 3 fields"),
        ("q2_deg,marker,x_mm\n", "no data rows"),
        ("", "the file is empty"),
        ("q2_deg,marker,x_mm,x_mm\n0,P1,1,1\n", "column 'x_mm' appears more than once"),
        ("q2_deg;marker;x_mm\n0;P1;1\n", "points.csv:1: the header is a single column; the file seems separated by ';'"),
        ("q2_deg\tmarker\tx_mm\n0\tP1\t1\n", "separated by '\\t'"),
    ],
)
def test_bad_files_give_one_line_errors_naming_the_place(tmp_path, text, expected):
    path = write(tmp_path, text)
    with pytest.raises(InputError) as raised:
        read_table(path, COLUMNS, units={"x_mm": "mm"})
    message = str(raised.value)
    assert expected in message
    assert "\n" not in message


@pytest.mark.parametrize("raw", ["7_9.20", "1_000", "0x1A", "infinity", "-inf", "1e400", "١٢", "1.2.3", "1e", "+-1", "1,5"])
def test_numbers_are_parsed_strictly(tmp_path, raw):
    # float() accepts the first three kinds (underscores, "infinity", non-ASCII digits) without complaint.
    path = write(tmp_path, f'q2_deg,marker,x_mm\n"{raw}",P1,1\n')
    with pytest.raises(InputError) as raised:
        read_table(path, COLUMNS)
    assert str(raised.value).startswith(f"{path}:2, column 'q2_deg': expected a number, got '{raw}'")


@pytest.mark.parametrize(("raw", "value"), [("79.20", 79.2), ("-.5", -0.5), ("+3.", 3.0), ("1e3", 1000.0), ("2.5E-3", 0.0025)])
def test_plain_decimal_numbers_are_read(tmp_path, raw, value):
    path = write(tmp_path, f"q2_deg,marker,x_mm\n{raw},P1,1\n")
    assert read_table(path, COLUMNS).loc[2, "q2_deg"] == value


def test_a_folder_is_not_a_missing_file(tmp_path):
    with pytest.raises(InputError, match="is a folder; expected a CSV file"):
        read_table(tmp_path, COLUMNS)


def test_integer_column_rejects_fractions(tmp_path):
    path = write(tmp_path, "config\n1.5\n")
    with pytest.raises(InputError, match="expected a whole number"):
        read_table(path, {"config": "integer"})


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_table(tmp_path / "absent.csv", COLUMNS)


def test_markdown_table():
    from bayescal.tables import markdown_table

    assert markdown_table(["a", "b"], [[1, "x"], [2.5, ""]]) == "| a | b |\n|---|---|\n| 1 | x |\n| 2.5 |  |"


def test_read_header_finds_the_first_row_after_comments(tmp_path):
    from bayescal.tables import read_header

    assert read_header(write(tmp_path, "\ufeff# note\n\nq2_deg, marker\n1,P1\n")) == (3, ["q2_deg", "marker"])
    assert read_header(write(tmp_path, "# only a note\n")) is None
    assert read_header(tmp_path / "absent.csv") is None


def test_columns_read_at_once_equal_those_parsed_value_by_value(tmp_path):
    from bayescal.tables import _parse

    path = tmp_path / "t.csv"
    path.write_text("a,b,c,d\n1, -2.5e-3 ,x,+.5\n7,3.,y z,-0\n-4,1E2,w,12\n")
    kinds = {"a": "integer", "b": "number", "c": "text", "d": "number"}
    frame = read_table(path, kinds)
    rows = [line.split(",") for line in path.read_text().splitlines()[1:]]
    for k, (name, kind) in enumerate(kinds.items()):
        expected = [_parse(row[k].strip(), kind, name, None, str(path), 0) for row in rows]
        assert frame[name].tolist() == expected
        assert [type(v) for v in frame[name].tolist()] == [type(v) for v in expected]
