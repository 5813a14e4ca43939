"""The tests' Markdown table reader: the pages' tests rely on it reading every cell."""
import pytest

from pages import page_headers, page_tables


def test_a_row_with_a_cell_too_few_is_refused():
    with pytest.raises(ValueError, match="2 cells under a header of 3"):
        page_tables("| a | b | c |\n|--|--|--|\n| 1 | 2 |\n")


def test_escaped_bars_stay_inside_their_cell():
    page = "text\n\n| case | message |\n|---|---|\n| s | \\|s\\| > 1 |\n\nmore\n"
    assert page_tables(page) == [[{"case": "s", "message": "|s| > 1"}]]
    assert page_headers(page) == [["case", "message"]]


def test_an_aligned_table_is_cut_at_its_separators_bars():
    page = ("| max |λ| | n |\n"
            "|:--------|--:|\n"
            "|     2.5 | 3 |\n")
    assert page_headers(page) == [["max |λ|", "n"]]
    assert page_tables(page) == [[{"max |λ|": "2.5", "n": "3"}]]


def test_a_row_as_long_as_the_separator_but_not_aligned_is_split_at_its_bars():
    page = "| x | y |\n|--|----|\n| 1 | 2 |\n"
    assert page_tables(page) == [[{"x": "1", "y": "2"}]]


def test_lines_without_a_separator_are_not_a_table():
    page = "| a quoted line |\n\n| x | y |\n|---|---|\n| 1 | 2 |\n"
    assert page_tables(page) == [[{"x": "1", "y": "2"}]]
    assert page_headers(page) == [["x", "y"]]
