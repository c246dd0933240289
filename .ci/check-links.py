#!/usr/bin/env python3
"""Checks the relative links of a built mdBook: every href/src that names a file inside the book
must point to a file that exists, and a #fragment to an id in that file.

    .ci/check-links.py docs/guide/book

Links with a scheme (https:, mailto:) are not fetched: CI stays offline and fast. Exit 1 with one
line per broken link (page, link, why), 0 when all resolve."""
import html.parser
import os
import sys
import urllib.parse


class Page(html.parser.HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.links, self.ids = [], set()

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name in ("id", "name") and value:
                self.ids.add(value)
            if value and ((name == "href" and tag in ("a", "link")) or (name == "src" and tag in ("img", "script"))):
                self.links.append(value)


def parse(path, cache={}):
    if path not in cache:
        page = Page()
        with open(path, encoding="utf-8") as f:
            page.feed(f.read())
        cache[path] = page
    return cache[path]


def main(root):
    root = os.path.abspath(root)
    if not os.path.isfile(os.path.join(root, "index.html")):
        sys.exit(f"check-links: {root} has no index.html (build the book first)")
    broken, checked = [], 0
    for folder, _, files in os.walk(root):
        for name in sorted(files):
            if not name.endswith(".html"):
                continue
            page_path = os.path.join(folder, name)
            for link in parse(page_path).links:
                parts = urllib.parse.urlsplit(link)
                if parts.scheme or parts.netloc or link.startswith("//"):
                    continue
                checked += 1
                target = page_path
                if parts.path:
                    target = os.path.normpath(os.path.join(folder, urllib.parse.unquote(parts.path)))
                    if os.path.isdir(target):
                        target = os.path.join(target, "index.html")
                where = f"{os.path.relpath(page_path, root)}: {link}"
                if not target.startswith(root + os.sep):
                    broken.append(f"{where}: leaves the book ({os.path.relpath(target, root)})")
                elif not os.path.isfile(target):
                    broken.append(f"{where}: no such file")
                elif parts.fragment and target.endswith(".html"):
                    if urllib.parse.unquote(parts.fragment) not in parse(target).ids:
                        broken.append(f"{where}: no id `{parts.fragment}` in {os.path.relpath(target, root)}")
    for line in broken:
        print(f"check-links: {line}")
    print(f"check-links: {checked} relative links, {len(broken)} broken", file=sys.stderr)
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "docs/guide/book"))
