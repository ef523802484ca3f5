"""The built docs in a real browser (Debian's chromium, driven by Playwright) at 1280x800: what a reader sees.

The API pages must show no raw Sphinx role (``:func:`...```: scripts/griffe_sphinx_roles.py renders them),
and neither they nor the leaderboard may need a sideways scroll: the page and every table fit the width.
The screenshots land in docs/images/ (the docs and the README may show them).
"""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

# End to end (see pyproject.toml's markers): left out of the default unit tier, run by .ci/run.
pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
VIEWPORT = {"width": 1280, "height": 800}
RAW_ROLE = re.compile(r":(?:py:)?(?:func|class|data|mod|meth|attr|exc|obj|const):(?=\S)")  # `x` shows as x
API_PAGES = sorted(path.stem for path in (ROOT / "docs" / "api").glob("*.md") if path.stem != "index")
SCREENSHOTS = {"api/envs/": "docs_api_envs_1280x800.png", "leaderboard/": "docs_leaderboard_1280x800.png"}

playwright_api = pytest.importorskip("playwright.sync_api", reason="playwright is a test dependency (.[dev])")
if not Path(CHROMIUM).exists():
    pytest.skip("Debian's chromium is not installed (.ci/setup installs it with apt-get)", allow_module_level=True)

# The page's own width, and each table's width against the width its wrapper shows (Material scrolls a wide
# table inside its wrapper instead of widening the page, so both are measured).
MEASURE = """() => {
  const tables = [];
  document.querySelectorAll('article table').forEach((table) => {
    const shown = (table.closest('.md-typeset__scrollwrap') || table.parentElement).clientWidth;
    const header = table.rows[0].innerText.slice(0, 60);
    if (table.scrollWidth > shown + 1) tables.push(`${header}: ${table.scrollWidth} > ${shown}`);
  });
  const headings = [...document.querySelectorAll('article h3')].map((heading) => heading.id);
  const text = document.querySelector('article').innerText;
  return {page: document.documentElement.scrollWidth, tables, headings, text};
}"""


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built with ``mkdocs build --strict`` (a warning fails the build, so this checks it too)."""
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    command = [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)]
    built = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stderr[-3000:]
    return out


@pytest.fixture(scope="module")
def browser():
    with playwright_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield browser
        browser.close()


def seen(browser, site, page_path):
    """What chromium shows of ``page_path`` at 1280x800 (screenshot saved if it is one of the docs')."""
    page = browser.new_page(viewport=VIEWPORT)
    page.goto((site / page_path / "index.html").as_uri())
    measured = page.evaluate(MEASURE)
    if page_path in SCREENSHOTS:
        IMAGES.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(IMAGES / SCREENSHOTS[page_path]))
    page.close()
    return measured


@pytest.mark.parametrize("name", API_PAGES)
def test_an_api_page_shows_no_raw_role_and_fits_1280_px(browser, site, name):
    measured = seen(browser, site, f"api/{name}/")
    raw = [match.start() for match in RAW_ROLE.finditer(measured["text"])]
    assert raw == [], f"raw roles on api/{name}: {[measured['text'][at : at + 60] for at in raw[:5]]}"
    assert measured["page"] <= VIEWPORT["width"]
    assert measured["tables"] == []


def test_the_api_pages_link_their_cross_references(site):
    # The roles became links, not only plain text: a page that lost its links would pass the test above.
    html = (site / "api" / "envs" / "index.html").read_text()
    assert html.count('class="autorefs autorefs-internal"') >= 20


def test_the_leaderboard_fits_1280_px_and_leads_with_one_table_per_suite(browser, site):
    measured = seen(browser, site, "leaderboard/")
    assert measured["page"] <= VIEWPORT["width"]
    assert measured["tables"] == []
    assert {"point5", "ant4", "u", "medium", "large", "giant"} <= set(measured["headings"])
