#!/usr/bin/env python3
"""Checks the repository's layout goals and prints a short report.

  (a) the binary's `src/` holds at most 4000 lines of Rust;
  (b) no import circle between the top-level modules ("rooms") of any crate: a room is
      the first path component under `src/` (the file stem for top-level files;
      `lib.rs` and `main.rs` belong to no room); an edge is a `crate::room` reference
      (`use crate::x`, `crate::x::…`, `use crate::{a, b}`); strongly connected
      components of more than one room are circles;
  (c) no shader source edited by string replacement: in a file that mentions WGSL or a
      shader, a `.replace(`/`.replacen(` whose statement names shader text (SHADER,
      LIBRARY, wgsl, shader, base, source, ENTRY) and whose arguments are not JSON;
  (d) no function over 120 lines in the renderer crates, counted from its `fn` line to
      its closing brace, `#[cfg(test)]` items and `tests/` left out.

Exits 1 when a check fails, unless `--report-only`. Python 3.11, standard library only.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SRC_LIMIT = 4000
FN_LIMIT = 120
RENDERER_CRATES = ["view", "scene", "fogfn", "wavelet", "gaussians"]
SHADER_WORDS = re.compile(r"\b(SHADER\w*|\w*LIBRARY\w*|\w*wgsl\w*|shader|base|source|ENTRY)\b")
SHADER_FILE = re.compile(r"wgsl|SHADER", re.IGNORECASE)
REPLACE = re.compile(r"\.replacen?\(")
JSON_ARG = re.compile(r'\\"|r#"')
SHOW = 8  # items listed per check
RAW_STRING = re.compile(r'b?r(#*)"')
CHAR = re.compile(r"'(\\(x[0-9a-fA-F]{2}|u\{[0-9a-fA-F]+\}|.)|[^\\'])'")


def blank_comments_and_strings(text: str) -> str:
    """The source with comments, string and char literals replaced by spaces (newlines
    kept), so braces and paths can be matched on what the compiler reads as code."""
    out = []
    i, n = 0, len(text)

    def blank(s: str) -> str:
        return "".join("\n" if c == "\n" else " " for c in s)

    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(blank(text[i:j]))
            i = j
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append(blank(text[i:j]))
            i = j
        elif (m := RAW_STRING.match(text, i)) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            end = '"' + m.group(1)
            j = text.find(end, m.end())
            j = n if j < 0 else j + len(end)
            out.append(blank(text[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(blank(text[i : j + 1]))
            i = j + 1
        elif c == "'":
            m = CHAR.match(text, i)
            if m:
                out.append(blank(m.group(0)))
                i = m.end()
            else:  # a lifetime or a label
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def rust_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*.rs") if "target" not in p.parts)


def crate_src_dirs() -> list[tuple[str, Path]]:
    dirs = [("haze (src/)", ROOT / "src")]
    for toml in sorted((ROOT / "crates").glob("*/Cargo.toml")):
        src = toml.parent / "src"
        if src.is_dir():
            dirs.append((f"crates/{toml.parent.name}", src))
    return dirs


# (a) ------------------------------------------------------------------------------------


def check_src_lines() -> tuple[bool, list[str]]:
    files = [(p, sum(1 for _ in p.open(encoding="utf-8"))) for p in rust_files(ROOT / "src")]
    total = sum(n for _, n in files)
    ok = total <= SRC_LIMIT
    lines = [f"(a) src/: {total} lines of Rust (limit {SRC_LIMIT}): {'ok' if ok else 'FAIL'}"]
    if not ok:
        for p, n in sorted(files, key=lambda t: -t[1])[:SHOW]:
            lines.append(f"    {n:6}  {p.relative_to(ROOT)}")
    return ok, lines


# (b) ------------------------------------------------------------------------------------

USE_GROUP = re.compile(r"\buse\s+crate\s*::\s*\{")
CRATE_PATH = re.compile(r"\bcrate\s*::\s*([A-Za-z_]\w*)")


def room_of(path: Path, src: Path) -> str | None:
    rel = path.relative_to(src)
    if len(rel.parts) > 1:
        return rel.parts[0]
    if rel.name in ("lib.rs", "main.rs"):
        return None
    return rel.stem


def group_heads(code: str, start: int) -> list[str]:
    """The first path component of each item of the group opened at `start` (`{`)."""
    depth, j, item_start, heads = 0, start, start + 1, []
    while j < len(code):
        ch = code[j]
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
            if depth == 0:
                heads.append(code[item_start:j])
                break
        elif ch == "," and depth == 1:
            heads.append(code[item_start:j])
            item_start = j + 1
        j += 1
    names = []
    for h in heads:
        m = re.match(r"\s*([A-Za-z_]\w*)", h)
        if m and m.group(1) not in ("self", "super"):
            names.append(m.group(1))
    return names


def room_edges(src: Path) -> tuple[dict[str, set[str]], dict[tuple[str, str], str]]:
    rooms: dict[str, set[str]] = {}
    files = rust_files(src)
    for p in files:
        r = room_of(p, src)
        if r:
            rooms.setdefault(r, set())
    witness: dict[tuple[str, str], str] = {}
    for p in files:
        r = room_of(p, src)
        if r is None:
            continue
        code = blank_comments_and_strings(p.read_text(encoding="utf-8"))
        targets = [m.group(1) for m in CRATE_PATH.finditer(code)]
        for m in USE_GROUP.finditer(code):
            targets += group_heads(code, m.end() - 1)
        for t in targets:
            if t in rooms and t != r:
                rooms[r].add(t)
                witness.setdefault((r, t), str(p.relative_to(ROOT)))
    return rooms, witness


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def check_circles() -> tuple[bool, list[str]]:
    found = []
    for name, src in crate_src_dirs():
        graph, witness = room_edges(src)
        for comp in strongly_connected(graph):
            if len(comp) > 1:
                found.append((name, comp, graph, witness))
    ok = not found
    lines = [f"(b) import circles between rooms: {len(found)}: {'ok' if ok else 'FAIL'}"]
    for name, comp, graph, witness in sorted(found, key=lambda t: -len(t[1]))[:SHOW]:
        lines.append(f"    {name}: {len(comp)} rooms: {', '.join(comp)}")
        members = set(comp)
        edges = [(a, b) for a in comp for b in sorted(graph[a]) if b in members]
        for a, b in edges[:4]:
            lines.append(f"        {a} -> {b}  ({witness[(a, b)]})")
        if len(edges) > 4:
            lines.append(f"        … {len(edges) - 4} more edges")
    return ok, lines


# (c) ------------------------------------------------------------------------------------


def statement_around(lines: list[str], k: int) -> str:
    """Line `k` with the earlier lines of its statement (a chained call's receiver)."""
    start = k
    while start > 0 and k - start < 6:
        prev = lines[start - 1].split("//")[0].rstrip()
        if not prev or prev.endswith((";", "{", "}")):
            break
        start -= 1
    return " ".join(lines[start : k + 1])


def check_shader_replace() -> tuple[bool, list[str]]:
    hits = []
    for p in rust_files(ROOT):
        if "vendor" in p.relative_to(ROOT).parts or "fuzz" in p.relative_to(ROOT).parts:
            continue
        text = p.read_text(encoding="utf-8")
        if not SHADER_FILE.search(text):
            continue
        lines = text.split("\n")
        for k, line in enumerate(lines):
            code = line.split("//")[0] if not line.lstrip().startswith("//") else ""
            if not REPLACE.search(code) or JSON_ARG.search(code):
                continue
            if SHADER_WORDS.search(statement_around(lines, k)):
                hits.append(f"{p.relative_to(ROOT)}:{k + 1}: {line.strip()}")
    ok = not hits
    lines = [f"(c) shader source edited by string replacement: {len(hits)}: {'ok' if ok else 'FAIL'}"]
    lines += [f"    {h}" for h in hits[:SHOW]]
    if len(hits) > SHOW:
        lines.append(f"    … {len(hits) - SHOW} more")
    return ok, lines


# (d) ------------------------------------------------------------------------------------

FN = re.compile(r"\bfn\s+([A-Za-z_]\w*)")
CFG_TEST = re.compile(r"#\s*\[\s*cfg\s*\(\s*test\s*\)\s*\]")


def matching_brace(code: str, open_at: int) -> int:
    depth = 0
    for j in range(open_at, len(code)):
        if code[j] == "{":
            depth += 1
        elif code[j] == "}":
            depth -= 1
            if depth == 0:
                return j
    return len(code) - 1


def long_functions(path: Path) -> list[tuple[int, str, int]]:
    code = blank_comments_and_strings(path.read_text(encoding="utf-8"))
    # Spans of #[cfg(test)] items: from the attribute to the end of the item's body.
    skipped: list[tuple[int, int]] = []
    for m in CFG_TEST.finditer(code):
        j = m.end()
        while j < len(code) and code[j] not in "{;":
            j += 1
        end = matching_brace(code, j) if j < len(code) and code[j] == "{" else j
        skipped.append((m.start(), end))
    out = []
    for m in FN.finditer(code):
        if any(a <= m.start() <= b for a, b in skipped):
            continue
        j = m.end()
        depth = 0  # `{` of the body: the first one outside parentheses and generics
        while j < len(code):
            ch = code[j]
            if ch in "(<[":
                depth += 1
            elif ch in ")>]":
                depth -= 1 if code[j - 1] != "-" else 0  # `->` is not a bracket
            elif ch == ";" and depth <= 0:
                j = -1  # a declaration without a body
                break
            elif ch == "{" and depth <= 0:
                break
            j += 1
        if j < 0 or j >= len(code):
            continue
        end = matching_brace(code, j)
        first = code.count("\n", 0, m.start()) + 1
        last = code.count("\n", 0, end) + 1
        n = last - first + 1
        if n > FN_LIMIT:
            out.append((first, m.group(1), n))
    return out


def check_function_length() -> tuple[bool, list[str]]:
    found = []
    for c in RENDERER_CRATES:
        src = ROOT / "crates" / c / "src"
        for p in rust_files(src):
            for line, name, n in long_functions(p):
                found.append((n, f"{p.relative_to(ROOT)}:{line} {name}"))
    found.sort(reverse=True)
    ok = not found
    lines = [
        f"(d) functions over {FN_LIMIT} lines in {', '.join(RENDERER_CRATES)}: "
        f"{len(found)}: {'ok' if ok else 'FAIL'}"
    ]
    lines += [f"    {n:5} lines  {where}" for n, where in found[:SHOW]]
    if len(found) > SHOW:
        lines.append(f"    … {len(found) - SHOW} more")
    return ok, lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--report-only", action="store_true", help="print the report, never fail")
    args = ap.parse_args()
    ok = True
    for check in (check_src_lines, check_circles, check_shader_replace, check_function_length):
        passed, lines = check()
        ok &= passed
        print("\n".join(lines))
    print("layout: ok" if ok else "layout: violations found")
    return 0 if ok or args.report_only else 1


if __name__ == "__main__":
    sys.exit(main())
