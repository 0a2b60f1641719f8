"""Checks the built documentation: every page is there, every internal link resolves, and the
pages render in a browser.

    check_site.py DOCS_SOURCE HTML_DIR WORKDIR [--no-browser]

1. Pages: every docs/**/*.md has its .html, whose <h1> is the source's first heading; and the
   README's relative links (into docs/) name existing files.
2. Links: every href and src in every built page that stays inside the site (not http:, https:,
   mailto:) names an existing file, and its #fragment an id or name in that file (html.parser).
3. Browser: headless Chromium (Debian's `chromium`) loads one harness page that holds every
   page in an iframe, and a script there reads each rendered page (its <h1>, whether its
   stylesheets applied, its links to other pages) into the harness's DOM, which --dump-dom
   prints. One browser start for the whole site keeps this to a few seconds of CPU.
Exit status 77 (ctest: skipped) when chromium is missing; 1 on any failure, with every problem
listed.
"""
import html
import html.parser
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import urllib.parse

problems = []


def problem(text):
    problems.append(text)
    print("FAIL:", text, flush=True)


class Page(html.parser.HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.ids, self.refs, self.h1, self._in_h1 = set(), [], [], 0

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        for key in ("id", "name") if tag in ("a", "span", "div", "section", "dt", "p",
                                             "h1", "h2", "h3", "h4", "table", "li", "dl",
                                             "figure", "img", "code", "pre") else ("id",):
            if attrs.get(key):
                self.ids.add(attrs[key])
        if attrs.get("id"):
            self.ids.add(attrs["id"])
        for key in ("href", "src"):
            if attrs.get(key) is not None and tag in ("a", "link", "script", "img", "iframe"):
                self.refs.append((tag, attrs[key]))
        if tag == "h1":
            self._in_h1 += 1
            self.h1.append("")

    def handle_endtag(self, tag):
        if tag == "h1" and self._in_h1:
            self._in_h1 -= 1

    def handle_data(self, data):
        if self._in_h1:
            self.h1[-1] += data


def normalise(title):
    title = title.replace("`", "").replace("\u00b6", "")
    return re.sub(r"\s+", " ", title).strip().rstrip("#").strip()


def expected_pages(source):
    pages = {}
    for md in sorted(source.rglob("*.md")):
        rel = md.relative_to(source)
        if rel.parts[0].startswith("_"):
            continue
        first = next((line for line in md.read_text().splitlines() if line.startswith("# ")), None)
        if first is None:
            problem(f"{rel}: no '# ' title")
            continue
        pages[rel.with_suffix(".html").as_posix()] = normalise(first[2:])
    return pages


def check_pages_and_links(source, site):
    parsed = {}
    for path in sorted(site.rglob("*.html")):
        page = Page()
        page.feed(path.read_text(errors="replace"))
        parsed[path.resolve()] = page
    pages = expected_pages(source)
    for rel, title in pages.items():
        page = parsed.get((site / rel).resolve())
        if page is None:
            problem(f"{rel}: not built")
            continue
        h1 = [normalise(h) for h in page.h1]
        if title not in h1:
            problem(f"{rel}: <h1> is {h1}, expected {title!r}")
    checked = 0
    for path, page in parsed.items():
        for tag, ref in page.refs:
            url = urllib.parse.urlsplit(ref)
            if url.scheme in ("http", "https", "mailto", "data", "javascript"):
                continue
            if url.scheme or url.netloc:
                problem(f"{path.relative_to(site.resolve())}: <{tag}> {ref}: unexpected scheme")
                continue
            target = path if not url.path else (path.parent / urllib.parse.unquote(url.path))
            target = target.resolve()
            if target.is_dir():
                target = target / "index.html"
            where = f"{path.relative_to(site.resolve())}: <{tag}> {ref}"
            checked += 1
            if not target.is_file():
                problem(f"{where}: no such file")
                continue
            if url.fragment and target.suffix == ".html":
                ids = parsed[target].ids if target in parsed else set()
                if urllib.parse.unquote(url.fragment) not in ids:
                    problem(f"{where}: no anchor #{url.fragment} in {target.name}")
    print(f"links: {checked} internal references in {len(parsed)} pages checked", flush=True)
    return pages


def check_readme_links(readme):
    """The README's relative links (into docs/ and elsewhere in the tree) name existing files."""
    checked = 0
    for target in re.findall(r"\]\(([^)\s]+)\)", readme.read_text()):
        url = urllib.parse.urlsplit(target)
        if url.scheme or not url.path:
            continue
        checked += 1
        if not (readme.parent / url.path).exists():
            problem(f"{readme.name}: link to {target}: no such file")
    print(f"readme: {checked} relative links checked", flush=True)


HARNESS = """<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>docs check</title></head>
<body>
<pre id="report">pending</pre>
{frames}
<script>
window.addEventListener("load", function () {{
  var out = [];
  document.querySelectorAll("iframe").forEach(function (frame) {{
    var entry = {{page: frame.dataset.page}};
    try {{
      var doc = frame.contentDocument;
      var h1 = doc.querySelector("h1");
      entry.h1 = h1 ? h1.textContent : null;
      entry.stylesheets = doc.styleSheets.length;
      entry.font = frame.contentWindow.getComputedStyle(doc.body).fontFamily;
      entry.sidebar_links = doc.querySelectorAll(".sidebar-tree a.reference").length;
      entry.text_length = doc.body.innerText.length;
    }} catch (e) {{
      entry.error = String(e);
    }}
    out.push(entry);
  }});
  document.getElementById("report").textContent = JSON.stringify(out);
}});
</script>
</body></html>
"""


def check_in_browser(site, pages, workdir, chromium):
    frames = "\n".join(
        f'<iframe data-page="{html.escape(rel)}" src="{(site / rel).resolve().as_uri()}" '
        'width="1200" height="800"></iframe>' for rel in pages)
    harness = workdir / "harness.html"
    harness.write_text(HARNESS.format(frames=frames))
    profile = workdir / "chromium-profile"
    command = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
               "--disable-extensions", "--disable-dev-shm-usage", "--allow-file-access-from-files",
               f"--user-data-dir={profile}", "--virtual-time-budget=10000", "--dump-dom",
               harness.as_uri()]
    try:
        proc = subprocess.run(command, capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        problem("chromium did not finish within 120 s")
        return
    m = re.search(r'<pre id="report">(.*?)</pre>', proc.stdout, re.S)
    if proc.returncode != 0 or not m:
        problem(f"chromium exited with {proc.returncode} and no report; stderr:\n"
                + proc.stderr[-2000:])
        return
    text = html.unescape(m.group(1))
    if text == "pending":
        problem("the harness's script did not run in chromium")
        return
    report = json.loads(text)
    for entry in report:
        rel = entry["page"]
        if entry.get("error"):
            problem(f"{rel} in chromium: {entry['error']}")
            continue
        if normalise(entry.get("h1") or "") != pages[rel]:
            problem(f"{rel} in chromium: <h1> {entry.get('h1')!r}, expected {pages[rel]!r}")
        if not entry.get("stylesheets"):
            problem(f"{rel} in chromium: no stylesheet loaded")
        if "serif" == (entry.get("font") or "").strip().lower() or "Times" in (entry.get("font") or ""):
            problem(f"{rel} in chromium: the theme's font did not apply ({entry.get('font')})")
        if entry.get("sidebar_links", 0) < len(pages) - 1:
            problem(f"{rel} in chromium: the navigation shows {entry.get('sidebar_links')} links "
                    f"for {len(pages)} pages")
        if entry.get("text_length", 0) < 200:
            problem(f"{rel} in chromium: only {entry.get('text_length')} characters of text")
    print(f"browser: {len(report)} pages rendered in chromium", flush=True)


def main():
    source, site, workdir = (pathlib.Path(a) for a in sys.argv[1:4])
    workdir.mkdir(parents=True, exist_ok=True)
    if not (site / "index.html").is_file():
        print(f"no built documentation at {site}/index.html (Docs.Build makes it)")
        return 1
    pages = check_pages_and_links(source, site)
    check_readme_links(source.parent / "README.md")
    if "--no-browser" not in sys.argv[4:]:
        chromium = os.environ.get("CHROMIUM") or shutil.which("chromium")
        if not chromium:
            print("SKIPPED: no chromium (apt-get install -y chromium; scripts/setup.sh installs it)")
            return 77 if not problems else 1
        check_in_browser(site, pages, workdir, chromium)
    if problems:
        print(f"{len(problems)} problem(s)")
        return 1
    print("docs site OK:", len(pages), "pages")
    return 0


if __name__ == "__main__":
    sys.exit(main())
