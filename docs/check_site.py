"""Check a built documentation site for broken internal links and images, in headless Chromium.

The site folder (``mkdocs build`` writes ``site/``) is served on 127.0.0.1 by Python's
``http.server`` and crawled from its ``index.html`` with Chromium driven by playwright. Every page
reachable by internal links is opened; on each, every ``<a href>`` into the site is checked (the page
or file exists; a ``#fragment`` names an element on the target page), every image must load and
decode, and every request the page makes to the site (stylesheets, scripts, images, the search index)
must succeed. Links leaving the site are not followed.

    python docs/check_site.py site          # prints a summary, exit status 1 on a broken link

From Python (a test): ``check_site(site_dir)`` returns the list of broken links, each as
``"PAGE: TARGET (why)"``; :func:`crawl_site` returns the counts too. :func:`find_browser` says why no
browser can run (``(None, reason)``), for a test to skip with that reason.
"""

from __future__ import annotations

import functools
import http.server
import shutil
import sys
import threading
import urllib.error
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urldefrag, urlsplit

BROWSER_NAMES = ("chromium", "chromium-browser", "google-chrome")
BROWSER_ARGS = ["--headless", "--no-sandbox", "--disable-gpu"]


@dataclass
class SiteReport:
    pages: list[str] = field(default_factory=list)   # site paths opened in the browser
    links_checked: int = 0                           # distinct (page, target) links and images checked
    broken: list[str] = field(default_factory=list)  # "PAGE: TARGET (why)"


def find_browser() -> tuple[str | None, str | None]:
    """``(chromium executable, None)``, or ``(None, why not)`` when playwright or Chromium is missing."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return None, "playwright is not installed (pip install playwright)"
    exe = next((shutil.which(n) for n in BROWSER_NAMES if shutil.which(n)), None)
    if exe is None:
        return None, "no Chromium binary on PATH (Debian: apt-get install chromium)"
    return exe, None


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # keep the crawl's output readable
        pass


class _Server(http.server.ThreadingHTTPServer):
    def handle_error(self, request, client_address):  # a browser closing a connection early is no error
        if not isinstance(sys.exc_info()[1], (BrokenPipeError, ConnectionResetError)):
            super().handle_error(request, client_address)


def _serve(site: Path):
    handler = functools.partial(_Quiet, directory=str(site))
    server = _Server(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    return server, f"http://127.0.0.1:{server.server_address[1]}"


def _is_page(url: str) -> bool:
    path = urlsplit(url).path
    return path.endswith("/") or path.endswith(".html")


def _status(url: str) -> int:
    try:
        with urllib.request.urlopen(urllib.request.Request(url, method="GET"), timeout=30) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


# collects, in the page, every link and image with what the browser resolved them to
_PAGE_SCRIPT = """() => ({
  links: Array.from(document.querySelectorAll('a[href]')).map(a => [a.getAttribute('href'), a.href]),
  images: Array.from(document.images).map(i => [i.getAttribute('src'), i.currentSrc || i.src,
                                               i.complete && i.naturalWidth > 0]),
  ids: Array.from(document.querySelectorAll('[id]')).map(e => e.id)
                .concat(Array.from(document.querySelectorAll('a[name]')).map(e => e.getAttribute('name'))),
})"""


def crawl_site(site_dir, *, start: str = "index.html", timeout_ms: int = 30000) -> SiteReport:
    """Crawl the built site in ``site_dir`` from ``start``; see the module docstring."""
    site = Path(site_dir)
    if not (site / start).is_file():
        raise FileNotFoundError(f"{site / start}: no built site here (run mkdocs build first)")
    exe, why = find_browser()
    if exe is None:
        raise RuntimeError(f"cannot check the site in a browser: {why}")
    from playwright.sync_api import sync_playwright

    report = SiteReport()
    server, base = _serve(site)
    seen_pages: dict[str, set[str]] = {}      # page url (no fragment) -> element ids on it
    fragments: list[tuple[str, str, str]] = []  # (from page, target page, fragment)
    checked: set[tuple[str, str]] = set()
    reported: set[str] = set()                 # image urls already reported as broken
    other_status: dict[str, int] = {}
    queue = [f"{base}/{start}"]
    referrer: dict[str, str] = {queue[0]: "(start)"}  # page url -> the first page that linked to it

    def internal(url: str) -> bool:
        return url.startswith(base + "/") or url == base

    def name(url: str) -> str:
        return url[len(base):] or "/"

    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=exe, args=BROWSER_ARGS)
            page = browser.new_page()
            failed: list[str] = []
            page.on("requestfailed", lambda r: failed.append(f"{r.url} (request failed: {r.failure})")
                    if internal(r.url) else None)
            page.on("response", lambda r: failed.append(f"{r.url} (HTTP {r.status})")
                    if internal(r.url) and r.status >= 400 else None)
            # nothing outside the site is fetched: the check works offline and tests only the site
            page.route("**/*", lambda route: route.continue_() if internal(route.request.url) else route.abort())
            while queue:
                url = queue.pop(0)
                if url in seen_pages:
                    continue
                failed.clear()
                resp = page.goto(url, wait_until="load", timeout=timeout_ms)
                if resp is None or resp.status >= 400:
                    seen_pages[url] = set()
                    report.broken.append(f"{name(referrer[url])}: {name(url)} "
                                         f"(HTTP {resp.status if resp else 'no response'})"
                                         if referrer[url] != "(start)" else f"{name(url)}: (start page did not load)")
                    continue
                page.wait_for_load_state("networkidle", timeout=timeout_ms)
                info = page.evaluate(_PAGE_SCRIPT)
                seen_pages[url] = set(info["ids"])
                report.pages.append(name(url))
                here = name(url)
                for src, resolved, ok in info["images"]:
                    if (here, resolved) in checked:
                        continue
                    checked.add((here, resolved))
                    if not ok:
                        report.broken.append(f"{here}: image {src} (not loaded)")
                        reported.add(resolved)
                for href, resolved in info["links"]:
                    if not internal(resolved):
                        continue
                    target, frag = urldefrag(resolved)
                    if (here, resolved) in checked:
                        continue
                    checked.add((here, resolved))
                    if _is_page(target):
                        if target not in seen_pages and target not in queue:
                            queue.append(target)
                            referrer.setdefault(target, url)
                        if frag:
                            fragments.append((here, target, unquote(frag)))
                    else:
                        if target not in other_status:
                            other_status[target] = _status(target)
                        if other_status[target] >= 400:
                            report.broken.append(f"{here}: {href} (HTTP {other_status[target]})")
                for f in sorted(set(failed)):
                    if f.split(" ", 1)[0] not in reported:
                        report.broken.append(f"{here}: {f.replace(base, '')}")
            browser.close()
    finally:
        server.shutdown()
        server.server_close()

    for here, target, frag in fragments:
        ids = seen_pages.get(target)
        if ids is not None and report.pages.count(name(target)) and frag not in ids:
            report.broken.append(f"{here}: {name(target)}#{frag} (no element with id {frag!r})")
    report.links_checked = len(checked)
    return report


def check_site(site_dir) -> list[str]:
    """The broken internal links and images of the built site in ``site_dir`` (empty: none)."""
    return crawl_site(site_dir).broken


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    site = Path(args[0] if args else "site")
    rep = crawl_site(site)
    print(f"{len(rep.pages)} pages, {rep.links_checked} links and images checked, {len(rep.broken)} broken")
    for b in rep.broken:
        print("  " + b)
    return 1 if rep.broken else 0


if __name__ == "__main__":
    sys.exit(main())
