#!/usr/bin/env python3
"""Structure checks of Corvid's tree (issue 24): the import graph and function lengths.

  scripts/tree_check.py graph     print the module import graph's cycles (a module is a
                                  .c file and its .h of the same name); exit 1 if any
  scripts/tree_check.py dot       the whole import graph in Graphviz's dot language
  scripts/tree_check.py functions list functions over 120 lines outside tests/; exit 1 if any
  scripts/tree_check.py state     list process-wide mutable variables (file-scope, not const) in
                                  library code whose line, or the comment just above it, does not
                                  say "process-wide" and why; exit 1 if any
  scripts/tree_check.py library   library code that reads the environment (getenv) or prints
                                  (stdout/stderr) instead of taking configuration structs and
                                  logging through the sink (corvid/log.h); exit 1 if any
  scripts/tree_check.py all       all four (the ctest `tree_structure` runs this)

An edge A -> B means a file of module A includes B's header ("b.h" or <corvid/b.h>), resolved
the way the build resolves it: first beside the including file, then in every include/ folder
of the tree. Files generated at build time and system headers are not modules.
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SKIP_DIRS = {".git", "build", "out", ".gl", ".carry"}
MAX_FUNCTION_LINES = 120
INCLUDE_RE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')


def source_files():
    for dirpath, dirnames, filenames in os.walk(ROOT):
        dirnames[:] = sorted(d for d in dirnames if d not in SKIP_DIRS and not d.startswith("build"))
        for name in sorted(filenames):
            if name.endswith((".c", ".h")):
                yield os.path.relpath(os.path.join(dirpath, name), ROOT)


def module_of(path):
    """foo/src/x.c and foo/include/corvid/x.h are both module foo:x (one concept, one name)."""
    parts = path.split(os.sep)
    top = parts[0]
    stem = os.path.splitext(parts[-1])[0]
    if stem.endswith("_internal"):  # x_internal.h is module x's private header
        stem = stem[: -len("_internal")]
    return top + ":" + stem


def build_graph(files):
    by_header = {}
    for f in files:
        if f.endswith(".h"):
            by_header.setdefault(os.path.basename(f), []).append(f)
    include_dirs = [f for f in files if f.endswith(".h") and "/include/" in "/" + f]
    edges = {}
    for f in files:
        mod = module_of(f)
        edges.setdefault(mod, set())
        with open(os.path.join(ROOT, f), encoding="utf-8", errors="replace") as fh:
            for line in fh:
                m = INCLUDE_RE.match(line)
                if not m:
                    continue
                target = resolve(f, m.group(1), files_set, include_dirs)
                if target and module_of(target) != mod:
                    edges[mod].add(module_of(target))
    return edges


def resolve(src, inc, files, include_headers):
    beside = os.path.normpath(os.path.join(os.path.dirname(src), inc))
    if beside in files:
        return beside
    for h in include_headers:
        if h.endswith("/include/" + inc) or h == "include/" + inc:
            return h
    # tests and benches include headers of src/ folders by plain name (target include dirs)
    base = os.path.basename(inc)
    candidates = [f for f in files if os.path.basename(f) == base and f.endswith(inc)]
    if len(candidates) == 1:
        return candidates[0]
    return None


def cycles(edges):
    """Tarjan's strongly connected components; every component of two or more is a loop."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        work = [(v, iter(sorted(edges.get(v, ()))))]
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        while work:
            node, it = work[-1]
            advanced = False
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                    advanced = True
                    break
                if w in on_stack:
                    low[node] = min(low[node], index[w])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == node:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return sorted(out, key=lambda c: (-len(c), c))


FUNC_START = re.compile(r"^[A-Za-z_][^;=]*\([^;]*$")


def long_functions(files):
    """Function bodies as clang-format writes them: a signature at column 0, its body closed
    by a '}' at column 0. Counts lines from the signature to the closing brace."""
    found = []
    for f in files:
        if not f.endswith(".c") or f.startswith("tests" + os.sep):
            continue
        with open(os.path.join(ROOT, f), encoding="utf-8", errors="replace") as fh:
            lines = fh.read().split("\n")
        i = 0
        while i < len(lines):
            line = lines[i]
            if FUNC_START.match(line) and not line.startswith(("typedef", "struct", "enum", "static const", "#")):
                j = i
                while j < len(lines) and "{" not in lines[j] and ";" not in lines[j]:
                    j += 1
                if j < len(lines) and lines[j].rstrip().endswith("{") and ";" not in lines[j]:
                    k = j + 1
                    while k < len(lines) and lines[k] != "}":
                        if lines[k] and not lines[k][0].isspace() and not lines[k].startswith(("#", "/", "*")):
                            break
                        k += 1
                    if k < len(lines) and lines[k] == "}":
                        length = k - i + 1
                        if length > MAX_FUNCTION_LINES:
                            name = re.search(r"([A-Za-z_0-9]+)\s*\(", line)
                            found.append((length, f, i + 1, name.group(1) if name else "?"))
                        i = k + 1
                        continue
            i += 1
    return sorted(found, reverse=True)


LIBRARY_DIRS = ("client", "server", "renderer", "scene", "image", "partition", "core", "media", "live", "web", "gateway")
STATE_RE = re.compile(r"^(static\s+)?(_Thread_local\s+|__thread\s+)?(volatile\s+)?"
                      r"(struct\s+\w+|_Atomic\([^)]*\)|[A-Za-z_]\w*)(\s+\w+)*[\s*]+\**\w+(\[[^]]*\])*\s*(=[^;]*)?;")


def undocumented_state(files):
    """File-scope mutable variables of library code: each must say why it is process-wide."""
    found = []
    for f in files:
        if not f.endswith(".c") or not f.startswith(LIBRARY_DIRS):
            continue
        with open(os.path.join(ROOT, f), encoding="utf-8", errors="replace") as fh:
            lines = fh.read().split("\n")
        depth = 0
        in_comment = False
        for i, line in enumerate(lines):
            stripped = line.strip()
            if depth > 0 and not in_comment and re.match(r"^\s+static\s+(?!const\b)[^(]*[=;]", line):
                window = " ".join(lines[max(0, i - 6): i + 1])
                if "process-wide" not in window:
                    found.append((f, i + 1, stripped))
            elif depth == 0 and not in_comment and re.match(r"^static\s+(struct|union)(\s+\w+)?\s*\{\s*$", line):
                window = " ".join(lines[max(0, i - 8): i + 1])
                if "process-wide" not in window:
                    found.append((f, i + 1, stripped))
            elif depth == 0 and not in_comment and STATE_RE.match(line) and "(" not in line.split("=")[0].replace("_Atomic(", ""):
                if not re.match(r"^(static\s+)?const\b", line) and not line.startswith(("extern", "typedef", "return")):
                    window = " ".join(lines[max(0, i - 6): i + 1])
                    if "process-wide" not in window:
                        found.append((f, i + 1, stripped))
            # track braces outside comments and strings, roughly
            code = re.sub(r'"(\\.|[^"\\])*"', '""', line)
            code = re.sub(r"'(\\.|[^'\\])*'", "''", code)
            if in_comment:
                if "*/" in code:
                    code = code.split("*/", 1)[1]
                    in_comment = False
                else:
                    continue
            code = re.sub(r"/\*.*?\*/", "", code)
            if "/*" in code:
                code = code.split("/*", 1)[0]
                in_comment = True
            code = code.split("//", 1)[0]
            depth += code.count("{") - code.count("}")
    return found


# Where library code may print: the log sink's default (stderr) is the one place.
PRINT_ALLOWED = {os.path.join("client", "src", "util", "log.c")}
LIBRARY_CALL_RE = re.compile(r"\b(getenv|secure_getenv)\s*\(|\bstderr\b|\bstdout\b|(?<![sn])\bprintf\s*\(|\bputs\s*\(|\bperror\s*\(")


def library_calls(files):
    """Library code takes configuration in structs and logs through one sink: no getenv, no prints."""
    found = []
    for f in files:
        if not f.endswith(".c") or not f.startswith(LIBRARY_DIRS):
            continue
        with open(os.path.join(ROOT, f), encoding="utf-8", errors="replace") as fh:
            text = fh.read()
        # blank comments and strings, keeping line numbers
        text = re.sub(r"/\*.*?\*/", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text, flags=re.S)
        text = re.sub(r"//[^\n]*", "", text)
        text = re.sub(r'"(\\.|[^"\\\n])*"', '""', text)
        for n, line in enumerate(text.split("\n"), 1):
            m = LIBRARY_CALL_RE.search(line)
            if not m:
                continue
            if f in PRINT_ALLOWED and "getenv" not in m.group(0):
                continue
            found.append((f, n, line.strip()))
    return found


def main(argv):
    global files_set
    what = argv[1] if len(argv) > 1 else "all"
    files = list(source_files())
    files_set = set(files)
    rc = 0
    if what in ("graph", "all", "dot"):
        edges = build_graph(files)
        if what == "dot":
            print("digraph corvid {")
            for a in sorted(edges):
                for b in sorted(edges[a]):
                    print(f'  "{a}" -> "{b}";')
            print("}")
            return 0
        loops = cycles(edges)
        print(f"import graph: {len(edges)} modules, {sum(len(e) for e in edges.values())} edges, "
              f"{len(loops)} include loop(s)")
        for comp in loops:
            print(f"  loop of {len(comp)}: " + " ".join(comp))
            members = set(comp)
            for a in comp:
                inside = sorted(b for b in edges[a] if b in members)
                print(f"    {a} -> {', '.join(inside)}")
        rc |= 1 if loops else 0
    if what in ("functions", "all"):
        longs = long_functions(files)
        print(f"functions over {MAX_FUNCTION_LINES} lines outside tests/: {len(longs)}")
        for length, f, line, name in longs:
            print(f"  {length:4d} lines  {f}:{line}  {name}")
        rc |= 1 if longs else 0
    if what in ("state", "all"):
        state = undocumented_state(files)
        print(f"process-wide variables without a 'process-wide: why' comment: {len(state)}")
        for f, line, text in state:
            print(f"  {f}:{line}  {text}")
        rc |= 1 if state else 0
    if what in ("library", "all"):
        calls = library_calls(files)
        print(f"library code reading the environment or printing: {len(calls)}")
        for f, line, text in calls:
            print(f"  {f}:{line}  {text}")
        rc |= 1 if calls else 0
    return rc


if __name__ == "__main__":
    sys.exit(main(sys.argv))
