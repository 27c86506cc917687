"""Screenshots of the built documentation site, as a newcomer's browser
shows it: Debian's headless chromium (devtools/chromium.py) opens each page
of docs/_build/html at 1280 x 800 and saves the first screen and the whole
page as PNGs, and reports what a reader would see broken: a page's console
errors and images that did not load; it counts the Panel/Bokeh outputs and
those that drew something.  Run after `make docs`:

    python -m devtools.docshots [--html docs/_build/html] [--out DIR] [PAGE ...]

PAGE is a path under the site (default: the front page, getting started,
the tutorials, the command-line and API references and every gallery
notebook).  Prints one JSON line per page; exits 1 when any page shows a
problem.
"""
import argparse
import json
import sys
from pathlib import Path

from devtools.chromium import launched

VIEWPORT = {"width": 1280, "height": 800}
# What a page shows broken, read in the page after it loaded: images with no
# pixels, and Bokeh roots (every Panel/Bokeh output) that drew no canvas.
PROBE = """() => {
  const broken = [...document.images].filter(i => i.complete && i.naturalWidth === 0)
                                     .map(i => i.getAttribute('src'));
  // a Bokeh root renders into its output cell (the root's own div may be
  // display: contents): the cell's height tells whether anything was drawn
  const roots = [...document.querySelectorAll('[data-root-id]')];
  // (pn.extension()'s own output is a root that draws nothing, so this is
  // reported, not judged)
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
            page.on("console", lambda m, errors=errors:
                    errors.append(m.text) if m.type == "error" else None)
            page.goto((html / page_path).resolve().as_uri(), wait_until="load")
            page.wait_for_timeout(settle_ms)       # Bokeh draws after load
            found = page.evaluate(PROBE)
            stem = page_path.removesuffix(".html").replace("/", "-")
            page.screenshot(path=str(out / f"docs-{stem}.png"))
            page.screenshot(path=str(out / f"docs-{stem}-full.png"), full_page=True)
            page.close()
            found.update(page=page_path, console_errors=errors,
                         ok=not errors and not found["broken_images"])
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
