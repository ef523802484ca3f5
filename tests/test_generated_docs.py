from pathlib import Path

import pytest
from script_helpers import load_script

pytestmark = pytest.mark.integration  # a lab check (scripts/generate_docs.py): the integration tier

ROOT = Path(__file__).resolve().parents[1]
generate_docs = load_script("scripts/generate_docs.py")

ECHO = "python -c \"print('| a |\\n|---|\\n| 1 |')\""


def page_with(tmp_path, body, name="page.md"):
    page = tmp_path / name
    page.write_text(body)
    return page


@pytest.mark.integration  # some 40 script subprocesses, each importing the package: minutes, not seconds
def test_every_generated_block_of_the_docs_matches_its_command(capsys):
    # The docs' tables printed from committed results: a results file or a printer that changes fails here.
    assert generate_docs.main(["--check"]) == 0, capsys.readouterr().out
    blocks = [
        block for page in generate_docs.default_pages() for block in generate_docs.find_blocks(page, page.read_text())
    ]
    assert len(blocks) >= 3  # the paper-experiment page's point and ant tables, the results pages' tables


def test_a_stale_block_is_reported_then_rewritten_and_the_rest_of_the_page_kept(tmp_path, capsys):
    page = page_with(
        tmp_path, f"# Title\n\nbefore\n<!-- generated: {ECHO} -->\n| a |\n|---|\n| 2 |\n<!-- end generated -->\nafter\n"
    )
    assert generate_docs.main(["--check", str(page)]) == 1
    assert f"{page}:4: stale" in capsys.readouterr().out
    assert "| 2 |" in page.read_text()  # --check writes nothing
    assert generate_docs.main([str(page)]) == 0
    assert (
        page.read_text()
        == f"# Title\n\nbefore\n<!-- generated: {ECHO} -->\n| a |\n|---|\n| 1 |\n<!-- end generated -->\nafter\n"
    )
    assert generate_docs.main(["--check", str(page)]) == 0


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (f"<!-- generated: {ECHO} -->\n| a |\n", r"page.md:1: a generated block has no '<!-- end generated -->'"),
        ("text\n<!-- end generated -->\n", r"page.md:2: '<!-- end generated -->' without"),
        (f"<!-- generated: {ECHO} -->\n<!-- generated: {ECHO} -->\n", r"page.md:2: a generated block starts inside"),
    ],
)
def test_unpaired_markers_name_the_page_and_line(tmp_path, body, message):
    page = page_with(tmp_path, body)
    with pytest.raises(generate_docs.BlockError, match=message):
        generate_docs.find_blocks(page, body)


@pytest.mark.parametrize(
    ("command", "message"),
    [
        ("bash -c 'rm -rf /'", r"must start with 'python', got \"bash -c 'rm -rf /'\""),
        ("python -c 'import sys; sys.exit(\"no results file\")'", r"exited 1: no results file"),
    ],
)
def test_a_command_that_is_not_python_or_fails_is_an_error_naming_it(tmp_path, capsys, command, message):
    page = page_with(tmp_path, f"<!-- generated: {command} -->\nold\n<!-- end generated -->\n")
    assert generate_docs.main([str(page)]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    with pytest.raises(generate_docs.BlockError, match=message):
        generate_docs.run_command(generate_docs.find_blocks(page, page.read_text())[0])
    assert "old" in page.read_text()
