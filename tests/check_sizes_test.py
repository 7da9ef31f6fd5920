#!/usr/bin/env python3
"""Tests scripts/check-sizes on a tree written here, whose sizes are known by construction:
functions of exactly the limit and over it (with lambdas, nested blocks and braces in
comments and strings inside), namespaces, classes and initialiser lists that are not functions,
files of 1,000 and 1,001 lines, and the allow-list.

Usage: check_sizes_test.py --script scripts/check-sizes
"""
import argparse
import importlib.machinery
import importlib.util
import io
import pathlib
import subprocess
import sys
import tempfile
from contextlib import redirect_stdout


FILLER = [  # ten lines, balanced: a lambda, braces in comments, strings and char literals
    "  auto f = [&](int y) {  // a lambda: its lines count toward the function",
    "    return y + 1;",
    "  };",
    '  const char* s = "}}}{";  // braces in a string',
    "  /* a comment { with a brace */",
    "  if (x > 0) {",
    "    x = f(x);",
    "  }",
    "  char c = '}';",
    "  int n = 1'000;",
]


def function(name, lines, header="void {}(int x) {{"):
    """A function of exactly `lines` lines from its `{` line to its `}` line."""
    inner = lines - 2
    body = FILLER * (inner // len(FILLER)) + ["  x += 1;"] * (inner % len(FILLER))
    return [header.format(name)] + body + ["}"]


def write_tree(root):
    src = root / "src"
    (src / "a").mkdir(parents=True)
    lines = ["#include <vector>", "namespace demo {", "namespace {", ""]
    lines += (function("atLimit", 150))
    lines += [""] + (function("overLimit", 151))
    lines += ["", "}  // namespace", ""]
    # A class whose inline member is over the limit, a constructor with an initialiser list.
    # The constructor's body follows an initialiser list whose braces initialise members.
    lines += ["class Widget {", " public:"]
    lines += function("Widget", 155, "  {}(int x) : v_{{1, 2}}, w_(3), u_{{x}} {{")
    lines += ["  " + l for l in (function("member", 160, "int {}() const {{"))]
    lines += ["  std::vector<int> v_;", "  int w_, u_;", "};", ""]
    lines += (function("Widget::trailing", 200, "auto {}(int x) -> int {{"))
    lines += ["", "}  // namespace demo", ""]
    (src / "a" / "funcs.cpp").write_text("\n".join(lines))
    (src / "a" / "exact.h").write_text("// x\n" * 1000)
    (src / "a" / "long.h").write_text("// x\n" * 1001)
    return src


def load(script):
    loader = importlib.machinery.SourceFileLoader("check_sizes", str(script))
    spec = importlib.util.spec_from_loader("check_sizes", loader)
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    return mod


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--script", required=True)
    a = ap.parse_args()
    failures = []

    def check(cond, what):
        if not cond:
            failures.append(what)

    with tempfile.TemporaryDirectory() as tmp:
        src = write_tree(pathlib.Path(tmp))
        r = subprocess.run([sys.executable, a.script, str(src)], capture_output=True, text=True)
        out = r.stdout
        check(r.returncode == 1, f"exit status {r.returncode}, expected 1 (things over limits)")
        check("function of 151 lines (limit 150): overLimit" in out, "overLimit (151) not reported")
        check("atLimit" not in out, "atLimit (exactly 150 lines) reported")
        check("function of 160 lines (limit 150): member" in out, "inline member (160) not reported")
        check("function of 200 lines (limit 150): Widget::trailing" in out,
              "trailing-return function (200) not reported")
        check("function of 155 lines (limit 150): Widget\n" in out,
              "constructor with an initialiser list (155) not reported")
        check("long.h: file of 1001 lines (limit 1000)" in out, "long.h (1001 lines) not reported")
        check("exact.h" not in out, "exact.h (1000 lines) reported")
        check("1 files over 1000 lines, 4 functions over 150 lines" in out,
              "wrong totals: " + out.strip().splitlines()[-1] if out.strip() else "no output")

        # The allow-list: the same tree passes when every finding is listed, and fails again when
        # one is not.
        mod = load(pathlib.Path(a.script))
        mod.ALLOWED = {"a/long.h", "a/funcs.cpp:overLimit", "a/funcs.cpp:member",
                       "a/funcs.cpp:Widget::trailing", "a/funcs.cpp:Widget"}
        sys.argv = ["check-sizes", str(src)]
        buf = io.StringIO()
        with redirect_stdout(buf):
            rc = mod.main()
        check(rc == 0, f"all findings allowed: exit status {rc}, expected 0")
        check("overLimit (allowed)" in buf.getvalue(), "allowed function not marked allowed")
        mod.ALLOWED = {"a/long.h", "a/funcs.cpp:overLimit", "a/funcs.cpp:member"}
        with redirect_stdout(io.StringIO()):
            rc = mod.main()
        check(rc == 1, f"one finding not allowed: exit status {rc}, expected 1")

        r = subprocess.run([sys.executable, a.script, str(src / "missing")], capture_output=True,
                           text=True)
        check(r.returncode == 1 and "error: not a directory" in r.stderr,
              "a missing root is not refused with an error")

    for f in failures:
        print("FAIL:", f)
    print(f"{len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
