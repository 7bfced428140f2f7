#!/usr/bin/env python3
"""Runs `petriplc check` over a public corpus of IEC 61131-3 code (scripts/conformance-public.sh
gives the sources on standard input) and prints per-file verdicts, the accepted share per
source, and a table of first errors by code.

Usage: conformance_public.py PETRIPLC SNAPSHOTS < sources

A `file` unit is one file checked alone; a `project` unit is a TwinCAT .plcproj checked whole,
each of its files judged by the errors located in it (a file with none is accepted only when
the whole project is: otherwise it is counted refused, by its project's first error, with the
code prefixed `dep:`). Files marked invalid (`?glob`) are a suite's tests of its own errors:
counted apart, where refusing them is right.
"""

import fnmatch
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections import Counter, defaultdict

TIMEOUT = 60
TEXT = (b".st", b".il", b".txt", b".xml", b".tcpou", b".tcdut", b".tcgvl", b".tcio", b".tctto", b".tctleo", b".plcproj", b".exp")
ERR = re.compile(r"^(?P<file>.+?)(:\d+:\d+)?(, [^:]*)?: error\[(?P<code>[A-Z]\d+)\]: (?P<msg>.*)$")
# What another helper of issue 29 builds, told apart in the table of first errors.
CAUSES = [
    ("object orientation", re.compile(r"\b(METHOD|PROPERTY|INTERFACE|EXTENDS|IMPLEMENTS|ACTION|THIS|SUPER)\b")),
    ("textual SFC", re.compile(r"\b(INITIAL_STEP|STEP|TRANSITION)\b")),
    ("EN/ENO", re.compile(r"\bEN(O)?\b")),
    ("WSTRING/CHAR", re.compile(r"\b(WSTRING|W?CHAR)\b|\(\"…\"\)")),
]


def cause(code, msg):
    for name, rx in CAUSES:
        if rx.search(msg):
            return name
    return code


def sources(lines):
    for line in lines:
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        name, repo, commit, dialect, unit, globs = (f.strip() for f in line.split("|", 5))
        yield dict(name=name, repo=repo, commit=commit, dialect=dialect, unit=unit, globs=globs.split())


def tree(snapshots, repo, commit, work):
    """The repository's files at `commit`, in a directory (extracted from a bare snapshot)."""
    key = repo.replace("/", "+")
    bare = os.path.join(snapshots, key, "repo")
    checkout = os.path.join(snapshots, key)
    if os.path.isdir(bare):
        out = os.path.join(work, key)
        if not os.path.isdir(out):
            # Blob by blob, text files only: a snapshot may lack its largest files (binaries),
            # which `git archive` would stop at.
            ls = subprocess.run(["git", "-C", bare, "ls-tree", "-r", "-z", commit], capture_output=True)
            if ls.returncode != 0:
                return None, ls.stderr.decode(errors="replace").strip()
            wanted = []
            for entry in ls.stdout.split(b"\0"):
                if b"\t" not in entry:
                    continue
                meta, path = entry.split(b"\t", 1)
                kind, oid = meta.split()[1:3]
                if kind == b"blob" and path.lower().endswith(TEXT):
                    wanted.append((oid, path.decode(errors="replace")))
            batch = subprocess.run(
                ["git", "-C", bare, "cat-file", "--batch"],
                input=b"".join(oid + b"\n" for oid, _ in wanted), capture_output=True,
            ).stdout
            pos = 0
            for _, path in wanted:
                nl = batch.index(b"\n", pos)
                head = batch[pos:nl].split()
                pos = nl + 1
                if head[-1] == b"missing":
                    continue
                size = int(head[2])
                dest = os.path.join(out, path)
                os.makedirs(os.path.dirname(dest), exist_ok=True)
                with open(dest, "wb") as f:
                    f.write(batch[pos:pos + size])
                pos += size + 1
            os.makedirs(out, exist_ok=True)
        return out, None
    if os.path.isdir(os.path.join(checkout, ".git")):
        head = subprocess.run(["git", "-C", checkout, "rev-parse", "HEAD"], capture_output=True, text=True).stdout
        if not head.startswith(commit):
            return None, f"checkout at {head[:12]}, not {commit}"
        return checkout, None
    return None, "not in PETRIPLC_PUBLIC"


def select(root, globs):
    include = [g for g in globs if not g.startswith(("!", "?"))]
    exclude = [g[1:] for g in globs if g.startswith("!")]
    invalid = [g[1:] for g in globs if g.startswith("?")]
    files = []
    for d, dirs, names in os.walk(root):
        dirs.sort()
        for n in sorted(names):
            rel = os.path.relpath(os.path.join(d, n), root)
            if any(fnmatch.fnmatch(rel, g) for g in include) and not any(fnmatch.fnmatch(rel, g) for g in exclude):
                files.append((rel, any(fnmatch.fnmatch(rel, g) for g in invalid)))
    return files


def check(petriplc, path, dialect, cwd):
    cmd = [petriplc, "check", path]
    if dialect != "auto":
        cmd += ["--dialect", dialect]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, errors="replace", cwd=cwd, timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        return False, [("", "timeout", f"no verdict in {TIMEOUT} s")]
    errors = []
    for line in (r.stdout + r.stderr).splitlines():
        m = ERR.match(line)
        if m:
            errors.append((m["file"], m["code"], m["msg"]))
    if r.returncode != 0 and not errors:
        first = (r.stderr.strip() or r.stdout.strip() or f"exit {r.returncode}").splitlines()[0]
        errors.append(("", "fail", first))
    return r.returncode == 0 and not errors, errors


def matiec_verdict(matiec, path, work):
    """matiec's iec2c on a Structured Text file: 'ok', 'refused' or '' (not a file it reads)."""
    if not matiec or not path.lower().endswith((".st", ".txt")):
        return ""
    out = tempfile.mkdtemp(dir=work)
    try:
        r = subprocess.run(
            [os.path.join(matiec, "iec2c"), "-I", os.path.join(matiec, "lib"), "-T", out, path],
            capture_output=True, timeout=TIMEOUT,
        )
        return "ok" if r.returncode == 0 else "refused"
    except subprocess.TimeoutExpired:
        return "timeout"
    finally:
        shutil.rmtree(out, ignore_errors=True)


def main():
    petriplc = os.path.abspath(sys.argv[1])
    snapshots = sys.argv[2]
    matiec = os.environ.get("PETRIPLC_MATIEC", "/work/tools/matiec")
    if not (os.path.exists(os.path.join(matiec, "iec2c")) or os.path.exists(os.path.join(matiec, "READY"))):
        matiec = ""
    out_file = os.environ.get("PETRIPLC_PUBLIC_OUT")
    rows = []  # (source, file, invalid, verdict, code, message, matiec)
    work = tempfile.mkdtemp(prefix="petriplc-public-")
    try:
        for src in sources(sys.stdin):
            root, why = tree(snapshots, src["repo"], src["commit"], work)
            if root is None:
                print(f"skipped {src['repo']}@{src['commit']}: {why}")
                continue
            for rel, invalid in select(root, src["globs"]):
                path = os.path.join(root, rel)
                label = f"{src['repo']}:{rel}"
                if src["unit"] == "project":
                    ok, errors = check(petriplc, path, src["dialect"], root)
                    proj_dir = os.path.dirname(path)
                    members = sorted(
                        os.path.relpath(os.path.join(d, n), root)
                        for d, _, ns in os.walk(proj_dir)
                        for n in ns
                        if n.lower().endswith((".tcpou", ".tcdut", ".tcgvl", ".tcio", ".tctto"))
                    )
                    by_file = defaultdict(list)
                    for f, code, msg in errors:
                        by_file[os.path.relpath(os.path.join(root, f), root) if f else ""].append((code, msg))
                    first = errors[0] if errors else None
                    for m in members:
                        own = by_file.get(m)
                        parses = not any(c.startswith("E0") for c, _ in own or [])
                        if ok:
                            rows.append((src["name"], f"{src['repo']}:{m}", invalid, "accepted", "", "", "", True))
                        elif own:
                            rows.append((src["name"], f"{src['repo']}:{m}", invalid, "refused", own[0][0], own[0][1], "", parses))
                        else:
                            rows.append((src["name"], f"{src['repo']}:{m}", invalid, "refused", "dep:" + first[1], first[2], "", parses))
                    continue
                ok, errors = check(petriplc, path, src["dialect"], root)
                mv = matiec_verdict(matiec, path, work)
                parses = not any(c.startswith(("E0", "fail", "timeout")) for _, c, _ in errors)
                if ok:
                    rows.append((src["name"], label, invalid, "accepted", "", "", mv, True))
                else:
                    _, code, msg = errors[0]
                    rows.append((src["name"], label, invalid, "refused", code, msg, mv, parses))
    finally:
        shutil.rmtree(work, ignore_errors=True)

    lines = []
    for name, label, invalid, verdict, code, msg, mv, _ in rows:
        kind = "invalid-on-purpose" if invalid else "valid"
        lines.append("\t".join([name, label, kind, verdict, code, msg[:160], mv]))
    print("# per-file verdicts: source, file, kind, petriplc, first error, message, matiec")
    for l in lines:
        print(l)
    if out_file:
        with open(out_file, "w") as f:
            f.write("\n".join(lines) + "\n")

    print()
    print("| source | files | accepted | share | parsed (no E0xx) |" + (" matiec accepts | matiec yes, petriplc no |" if matiec else ""))
    print("|---|---:|---:|---:|---:|" + ("---:|---:|" if matiec else ""))
    total = Counter()
    for name in dict.fromkeys(r[0] for r in rows):
        valid = [r for r in rows if r[0] == name and not r[2]]
        acc = sum(r[3] == "accepted" for r in valid)
        total["files"] += len(valid)
        total["acc"] += acc
        extra = ""
        if matiec:
            m_ok = sum(r[6] == "ok" for r in valid)
            gap = sum(r[6] == "ok" and r[3] != "accepted" for r in valid)
            extra = f" {m_ok} | {gap} |"
        share = f"{100 * acc / len(valid):.1f} %" if valid else "-"
        parsed = sum(r[7] for r in valid)
        total["parsed"] += parsed
        print(f"| {name} | {len(valid)} | {acc} | {share} | {parsed} |{extra}")
    if total["files"]:
        print(f"| all | {total['files']} | {total['acc']} | {100 * total['acc'] / total['files']:.1f} % | {total['parsed']} |")
    invalid = [r for r in rows if r[2]]
    if invalid:
        refused = sum(r[3] == "refused" for r in invalid)
        print(f"\ninvalid on purpose (a suite's tests of its errors): {refused} of {len(invalid)} refused")

    print("\n| first error (code, or the construct another branch builds) | files | example |")
    print("|---|---:|---|")
    codes = Counter(cause(r[4], r[5]) for r in rows if not r[2] and r[3] == "refused")
    for code, n in codes.most_common():
        ex = next(r for r in rows if not r[2] and r[3] == "refused" and cause(r[4], r[5]) == code)
        print(f"| {code} | {n} | {ex[1]}: {ex[5][:100]} |")


if __name__ == "__main__":
    main()
