#!/usr/bin/env python3
"""Runs the examples of the book and the README, and checks their links.

A fenced block whose info string is exactly ``sh`` is an example: it runs with
``bash -e -o pipefail``, the freshly built ``fiberlab`` first on PATH, in a new temporary
directory per page holding copies of ``examples/`` and ``scenes/`` (the blocks of one page run
in order in the same directory). With ``--python`` the ``python`` blocks run too, with the
Python that runs this script (it must have the ``fiberlab`` package). Any other info string
(``bash``, ``text``, ``console``, ``toml``, ...) is shown only. See
docs/book/src/contributing.md.

Every relative link and image of the pages must name an existing file, and every mdBook
``{{#include}}`` must resolve. Exits non-zero on the first failing example or on any broken
link, after printing what failed; the last line is ``N passed, M failed``.

Usage: python3 tools/book_examples.py [--python] [--fiberlab PATH] [--links-only] [FILE.md ...]
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BOOK = ROOT / "docs" / "book" / "src"
TIMEOUT_S = 300


def pages():
    """README.md and every page of the book, in a stable order."""
    return [ROOT / "README.md"] + sorted(BOOK.rglob("*.md"))


def fenced_blocks(text):
    """(first line number of the body, info string, body) of every fenced block."""
    blocks, fence, info, start, body = [], None, None, 0, []
    for number, line in enumerate(text.split("\n"), 1):
        stripped = line.lstrip(" ")
        if fence is None:
            m = re.match(r"(`{3,}|~{3,})(.*)$", stripped)
            if m and len(line) - len(stripped) < 4:
                fence, info, start, body = m.group(1), m.group(2).strip(), number + 1, []
        elif re.match(re.escape(fence[0]) + "{" + str(len(fence)) + r",}\s*$", stripped):
            blocks.append((start, info, "\n".join(body) + "\n"))
            fence = None
        else:
            body.append(line)
    return blocks


def prose(text):
    """The text outside fenced blocks and inline code, for the link check."""
    out, fence = [], None
    for line in text.split("\n"):
        stripped = line.lstrip(" ")
        m = re.match(r"(`{3,}|~{3,})", stripped)
        if fence is None and m:
            fence = m.group(1)
            continue
        if fence is not None:
            if re.match(re.escape(fence[0]) + "{" + str(len(fence)) + r",}\s*$", stripped):
                fence = None
            continue
        out.append(re.sub(r"`[^`]*`", "", line))
    return "\n".join(out)


def broken_links(page):
    """Relative links, images and includes of `page` that do not resolve."""
    text = page.read_text(encoding="utf-8")
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", prose(text)):
        if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            continue
        path = target.split("#")[0].split("?")[0]
        if path and not (page.parent / path).exists():
            broken.append(f"{page.relative_to(ROOT)}: link to {target}: no such file")
    # mdBook includes (a backslash before the braces escapes one).
    for m in re.finditer(r"(\\?)\{\{#include\s+([^}\s]+)\s*\}\}", text):
        if m.group(1):
            continue
        path = re.sub(r":[^/]*$", "", m.group(2))
        if not (page.parent / path).exists():
            broken.append(f"{page.relative_to(ROOT)}: {{{{#include {m.group(2)}}}}}: no such file")
    return broken


def run_page(page, blocks, env, python):
    """Runs the page's example blocks in order in one temporary directory; returns
    (passed, failure message or None)."""
    passed = 0
    with tempfile.TemporaryDirectory(prefix="fiberlab-book-") as tmp:
        for folder in ("examples", "scenes"):
            if (ROOT / folder).is_dir():
                shutil.copytree(ROOT / folder, Path(tmp) / folder)
        for line, info, body in blocks:
            where = f"{page.relative_to(ROOT)}:{line}"
            command = ["bash", "-e", "-o", "pipefail", "-c", body] if info == "sh" else [python, "-c", body]
            t0 = time.monotonic()
            try:
                done = subprocess.run(command, cwd=tmp, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
            except subprocess.TimeoutExpired:
                return passed, f"{where}: {info} block still running after {TIMEOUT_S} s"
            seconds = time.monotonic() - t0
            if done.returncode != 0:
                return passed, (
                    f"{where}: {info} block exited with status {done.returncode}\n--- block ---\n{body}"
                    f"--- stdout ---\n{done.stdout[-4000:]}--- stderr ---\n{done.stderr[-4000:]}"
                )
            print(f"ok   {where} ({info}, {seconds:.1f} s)", flush=True)
            passed += 1
    return passed, None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--python", action="store_true", help="also run the `python` blocks")
    parser.add_argument("--fiberlab", type=Path, help="the fiberlab binary (default: the release build)")
    parser.add_argument("--links-only", action="store_true", help="check the links, run nothing")
    parser.add_argument("files", nargs="*", type=Path, help="pages (default: README.md and the book)")
    args = parser.parse_args()
    files = [f.resolve() for f in args.files] or pages()

    broken = [b for f in pages() for b in broken_links(f)]
    for b in broken:
        print(f"FAIL {b}")
    if args.links_only:
        print(f"{len(pages()) - len(broken)} passed, {len(broken)} failed")
        return 1 if broken else 0

    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    binary = (args.fiberlab or target / "release" / "fiberlab").resolve()
    if not binary.is_file():
        print(f"FAIL {binary}: no fiberlab binary (build it with `cargo build --release`)")
        return 1
    env = dict(os.environ, PATH=f"{binary.parent}{os.pathsep}{os.environ.get('PATH', '')}")
    version = subprocess.run([str(binary), "--version"], capture_output=True, text=True, check=True).stdout.strip()
    print(f"running the examples with {version} ({binary})", flush=True)

    kinds = {"sh", "python"} if args.python else {"sh"}
    passed, failed, skipped = 0, len(broken), 0
    for page in files:
        blocks = fenced_blocks(page.read_text(encoding="utf-8"))
        skipped += sum(1 for _, info, _ in blocks if info == "python" and not args.python)
        runnable = [b for b in blocks if b[1] in kinds]
        if not runnable:
            continue
        ok, failure = run_page(page, runnable, env, sys.executable)
        passed += ok
        if failure:
            print(f"FAIL {failure}")
            failed += 1
            break
    if skipped:
        print(f"({skipped} python blocks not run: give --python to run them)")
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
