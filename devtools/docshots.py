"""Screenshots of the built documentation site (after `make docs`): each page
at 1280 x 800, first screen and whole page, with what a reader would see
broken (console errors, images not loaded) and the Bokeh outputs drawn.

    python -m devtools.docshots [--html docs/_build/html] [--out DIR] [PAGE ...]

Prints a JSON line per page; exits 1 when any page shows a problem.
"""

import argparse
import json
import sys
from pathlib import Path

from devtools.chromium import launched

VIEWPORT = {"width": 1280, "height": 800}
# images with no pixels; Bokeh roots and those whose output cell has a height
# (reported, not judged: pn.extension()'s own root draws nothing)
PROBE = """() => {
  const broken = [...document.images].filter(i => i.complete && i.naturalWidth === 0)
                                     .map(i => i.getAttribute('src'));
  const roots = [...document.querySelectorAll('[data-root-id]')];
  const drawn = roots.filter(r => ((r.closest('.cell_output, .output') || r.parentElement)
                                   .getBoundingClientRect().height) >= 50).length;
  return {broken_images: broken, bokeh_roots: roots.length, bokeh_roots_drawn: drawn,
          title: document.title};
}"""


def default_pages(html):
    pages = ["index.html", "getting-started.html"]
    for folder in ("tutorials", "how-to", "reference", "gallery"):
        pages += sorted(str(p.relative_to(html)) for p in (html / folder).glob("*.html"))
    return [p for p in pages if (html / p).exists()]


def shoot(html, out, pages, settle_ms=1500):
    """One screen and one full-page PNG of each page; a dict per page."""
    out.mkdir(parents=True, exist_ok=True)
    results = []
    with launched() as browser:
        for page_path in pages:
            page = browser.new_page(viewport=VIEWPORT)
            errors = []
            page.on("pageerror", lambda e, errors=errors: errors.append(str(e)))
            page.on("console", lambda m, errors=errors: errors.append(m.text) if m.type == "error" else None)
            page.goto((html / page_path).resolve().as_uri(), wait_until="load")
            page.wait_for_timeout(settle_ms)  # Bokeh draws after load
            found = page.evaluate(PROBE)
            stem = page_path.removesuffix(".html").replace("/", "-")
            page.screenshot(path=str(out / f"docs-{stem}.png"))
            page.screenshot(path=str(out / f"docs-{stem}-full.png"), full_page=True)
            page.close()
            found.update(page=page_path, console_errors=errors, ok=not errors and not found["broken_images"])
            results.append(found)
    return results


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("pages", nargs="*", help="pages under the site (default: the main ones)")
    parser.add_argument("--html", type=Path, default=Path("docs/_build/html"))
    parser.add_argument("--out", type=Path, default=Path("test-artifacts/docs"))
    args = parser.parse_args(argv)
    if not (args.html / "index.html").exists():
        parser.error(f"--html: no index.html in {args.html} (run `make docs` first)")
    results = shoot(args.html, args.out, args.pages or default_pages(args.html))
    for r in results:
        print(json.dumps(r))
    return 0 if all(r["ok"] for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
