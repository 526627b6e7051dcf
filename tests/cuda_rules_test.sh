#!/usr/bin/env bash
# Three things nvcc refuses that g++ accepts, checked without nvcc (docs/PERFORMANCE.md,
# "Building for more cores or a GPU"), so that a CUDA build does not break unseen:
#   1. a KOKKOS_LAMBDA in a GoogleTest test's body (the body is a member function, where nvcc
#      allows no extended lambda): a kernel in a test goes in a free function;
#   2. a range-for over a braced list whose first element has a type and a later one is itself
#      a bare braced list (`{std::pair("a", 1), {"b", 2}}`: nvcc 11.8 cannot deduce the
#      list's type, g++ and clang++ take it from the first): every element spelled out;
#   3. a lambda that captures a structured binding (ill-formed in C++17; clang++ says so, g++
#      does not): every project source of the build's compile_commands.json through
#      clang++ -fsyntax-only with the build's own flags.
#
#   tests/cuda_rules_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$1
build=$2

bad=$(awk 'FNR == 1 { inside = 0 } /^(TYPED_)?TEST(_F|_P)?\(/ { inside = 1 } /^}/ { inside = 0 }
  inside && /KOKKOS_LAMBDA/ { print FILENAME ":" FNR ": " $0 }' "$src"/tests/*.cpp)
if [ -n "$bad" ]; then
  echo "cuda_rules_test: a KOKKOS_LAMBDA in a test's body, which nvcc refuses (move the kernel" \
    "into a free function):" >&2
  echo "$bad" >&2
  exit 1
fi

/usr/bin/python3 - "$src" <<'PY'
import glob, os, re, sys

def skip_literal(text, i):
    # The index after the string or character literal starting at text[i].
    quote, i = text[i], i + 1
    while i < len(text) and text[i] != quote:
        i += 2 if text[i] == "\\" else 1
    return i + 1

def top_level(text, start, close):
    # The top-level pieces of text[start:] up to the bracket that closes it (`close`), split at
    # commas (and at a range-for's colon when close is ')'), with the index after the bracket.
    pieces, depth, i, piece = [], 0, start, start
    while i < len(text):
        c = text[i]
        if c in "\"'":
            i = skip_literal(text, i)
            continue
        if c in "([{":
            depth += 1
        elif c in ")]}":
            if depth == 0:
                pieces.append(text[piece:i])
                return pieces, i + 1
            depth -= 1
        elif depth == 0 and (c == "," or (close == ")" and c == ":" and text[i - 1:i + 1] != "::"
                                          and text[i:i + 2] != "::")):
            pieces.append(text[piece:i])
            piece = i + 1
        i += 1
    return pieces, i

bad = []
for name in sorted(sum((glob.glob(os.path.join(sys.argv[1], d, "*.[ch]pp"))
                        for d in ("src", "tests", "bench", "scenes", "kernels",
                                  "include/loosepack")), [])):
    text = open(name).read()
    for m in re.finditer(r"\bfor\s*\(", text):
        header, _ = top_level(text, m.end(), ")")
        if len(header) != 2 or not header[1].strip().startswith("{"):
            continue
        start = text.index("{", m.end() + len(header[0]) + 1)
        elements = [e.strip() for e in top_level(text, start + 1, "}")[0]]
        if elements and not elements[0].startswith("{") and any(e.startswith("{") for e in elements[1:]):
            bad.append(f"{name}:{text.count(chr(10), 0, m.start()) + 1}")
if bad:
    sys.exit("cuda_rules_test: a range-for over a braced list with bare braced elements after a "
             "typed first one, which nvcc refuses (spell out each element's type):\n  " +
             "\n  ".join(bad))
PY

/usr/bin/python3 - "$src" "$build/compile_commands.json" <<'PY'
import json, os, shlex, subprocess, sys
from concurrent.futures import ThreadPoolExecutor

src, commands = os.path.realpath(sys.argv[1]), sys.argv[2]
ours = [os.path.join(src, d) + os.sep for d in ("src", "tests", "bench", "scenes", "kernels")]

def clang_command(entry):
    args = shlex.split(entry["command"]) if "command" in entry else list(entry["arguments"])
    out, skip = ["clang++", "-fsyntax-only", "-Wno-unknown-warning-option"], False
    for a in args[1:]:
        if skip:
            skip = False
        elif a == "-o":
            skip = True
        elif a != "-c" and a != entry["file"]:
            out.append(a)
    return out + [entry["file"]]

entries = [e for e in json.load(open(commands))
           if any(os.path.realpath(e["file"]).startswith(d) for d in ours)]
if not entries:
    sys.exit(f"cuda_rules_test: no project source in {commands}")

def check(entry):
    r = subprocess.run(clang_command(entry), cwd=entry["directory"], capture_output=True,
                       text=True)
    return entry["file"], r.returncode, r.stderr

failed = 0
with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
    for name, rc, err in pool.map(check, entries):
        if rc != 0:
            failed += 1
            print(f"cuda_rules_test: clang++ refuses {name}:\n{err}", file=sys.stderr)
print(f"cuda_rules_test: {len(entries)} sources through clang++ -fsyntax-only, {failed} refused")
sys.exit(1 if failed else 0)
PY
