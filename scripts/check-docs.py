#!/usr/bin/env python3
"""Runs every command block a user would paste from README.md and docs/, so the docs cannot rot.

What runs:
- README.md's ```sh blocks, from the clone's root, in order, in one bash (`set -euo pipefail`);
- each docs/*.md's ```sh blocks, in order, in one bash started in a fresh folder that holds the
  clone as `icp-bench/` (docs/README.md states that convention to the reader);
- ```python blocks, by the Python of the README's venv (`.venv` at the clone's root, made by the
  README's install block), in the same working folder as the file's shell blocks at that point;
- the `run:` steps of docs/ci/github-actions.yml, after docs/gate.md, in the project that
  docs/gate.md made (its `working-directory` is that project): `uses:` steps that check out the
  user's repository or set up a toolchain are no-ops here; the checkout of icp-bench into
  `path:` becomes a link to this clone.
```rust blocks are not run here: icp-core compiles and runs them as doctests.

Every docs/ page that `icp-eval COMMAND --help` names, and every relative link of these pages (and of eval/ and datasets/'s READMEs) must name a file that
exists and, for a Markdown file, a heading it has.

A block is left out only when the line before it is `<!-- docs-check: skip REASON -->`, and every
such block is printed with its reason. The README's test command (`cargo test --workspace`) is
not run a second time: .ci/run runs it, and this script checks that .ci/run does.

`cargo install` puts the binary under a scratch CARGO_INSTALL_ROOT that is put on PATH, so the
machine's ~/.cargo/bin is left alone. Exit 0 when every block ran with status 0; 1 otherwise,
naming the file and line of the block that failed.
"""

import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

import yaml

REPO = pathlib.Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^```(\w*)\s*$")
SKIP = re.compile(r"^<!-- docs-check: skip (.+) -->$")
TEST_COMMAND = "cargo test --workspace"


def blocks(path):
    """(language, first line number, code, skip reason or None) for every fenced block."""
    lines = path.read_text().splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        lang, start = m.group(1), i + 1
        j = start
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        if j == len(lines):
            sys.exit(f"{path}:{i + 1}: a fenced block that is never closed")
        skip = SKIP.match(lines[i - 1]) if i > 0 else None
        out.append((lang, i + 1, "\n".join(lines[start:j]) + "\n", skip.group(1) if skip else None))
        i = j + 1
    return out


LINK = re.compile(r"\]\(([^)\s]+)\)")


def slug(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(path):
    lines = path.read_text().splitlines()
    return {slug(line.lstrip("#")) for line in lines if line.startswith("#")}


def broken_links(path):
    """Relative links of a Markdown file whose file, or heading, does not exist."""
    text = re.sub(r"```.*?```", "", path.read_text(), flags=re.S)
    out = []
    for url in LINK.findall(text):
        if re.match(r"^[a-z]+:", url):
            continue
        target, _, anchor = url.partition("#")
        dest = (path.parent / target).resolve() if target else path
        if not dest.exists():
            out.append(f"{path.relative_to(REPO)}: link to a missing file: {url}")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            out.append(f"{path.relative_to(REPO)}: link to a missing heading: {url}")
    return out


HELP_COMMANDS = ["run", "compare", "basin", "gate", "baseline", "synth", "merge"]


def broken_help_links(env):
    """docs/ pages that `icp-eval COMMAND --help` names and that do not exist."""
    out = []
    for command in HELP_COMMANDS:
        text = subprocess.run(
            ["icp-eval", command, "--help"], env=env, capture_output=True, text=True, check=True
        ).stdout
        for page in sorted(set(re.findall(r"docs/[\w./-]+\.(?:md|yml)", text))):
            if not (REPO / page).exists():
                out.append(f"icp-eval {command} --help names {page}, which does not exist")
    return out


def run_block(where, lang, code, cwd, env, python):
    """Runs one block; returns (status, the working folder after it)."""
    with tempfile.NamedTemporaryFile("w", suffix=".state", delete=False) as state:
        state_path = state.name
    if lang == "sh":
        script = f"set -euo pipefail\n{code}\npwd > {state_path}\n"
        status = subprocess.run(["bash", "-c", script], cwd=cwd, env=env).returncode
    else:
        script = f"{code}\nimport os\nopen({state_path!r}, 'w').write(os.getcwd())\n"
        status = subprocess.run([python, "-c", script], cwd=cwd, env=env).returncode
    after = pathlib.Path(pathlib.Path(state_path).read_text().strip() or cwd)
    os.unlink(state_path)
    if status != 0:
        print(f"docs-check: FAILED {where} (exit {status})", file=sys.stderr)
    return status, after


def check_test_command(readme_blocks):
    ci = (REPO / ".ci/run").read_text()
    said = [c for lang, _, c, _ in readme_blocks if lang == "sh" and TEST_COMMAND in c]
    if not said:
        sys.exit(f"README.md has no block with the test command `{TEST_COMMAND}`")
    if TEST_COMMAND not in ci:
        sys.exit(f".ci/run does not run the README's test command `{TEST_COMMAND}`")


def strip_test_command(code):
    """The README's quick-start block minus its test command (run by .ci/run itself)."""
    return "\n".join(line for line in code.splitlines() if TEST_COMMAND not in line) + "\n"


class Runner:
    def __init__(self, scratch):
        self.scratch = scratch
        self.env = dict(os.environ)
        self.env["CARGO_INSTALL_ROOT"] = str(scratch / "cargo-install")
        self.env["PATH"] = f"{scratch / 'cargo-install' / 'bin'}:{self.env['PATH']}"
        self.counts = {"ran": 0, "skipped": 0, "failed": 0}

    @property
    def python(self):
        venv_python = REPO / ".venv/bin/python"
        return str(venv_python) if venv_python.exists() else sys.executable

    def file(self, path, cwd):
        cwd = pathlib.Path(cwd)
        rel = path.relative_to(REPO)
        for lang, line, code, skip in blocks(path):
            if lang not in ("sh", "python"):
                continue
            where = f"{rel}:{line}"
            if skip:
                print(f"docs-check: skipped {where}: {skip}")
                self.counts["skipped"] += 1
                continue
            if path.name == "README.md" and path.parent == REPO and TEST_COMMAND in code:
                code = strip_test_command(code)
            print(f"docs-check: running {where} ({lang}) in {cwd}", flush=True)
            status, cwd = run_block(where, lang, code, cwd, self.env, self.python)
            self.counts["ran" if status == 0 else "failed"] += 1
            if status != 0:
                return None
        return cwd

    def workflow(self, path, project):
        """The run: steps of a GitHub Actions workflow, in the user's project."""
        rel = path.relative_to(REPO)
        flow = yaml.safe_load(path.read_text())
        for name, job in flow["jobs"].items():
            env = dict(self.env, **{k: str(v) for k, v in (flow.get("env") or {}).items()})
            env.update({k: str(v) for k, v in (job.get("env") or {}).items()})
            for i, step in enumerate(job["steps"]):
                where = f"{rel}: job {name}, step {i + 1} ({step.get('name') or step.get('uses')})"
                uses = step.get("uses")
                if uses:
                    target = (step.get("with") or {}).get("repository", "")
                    if uses.startswith("actions/checkout") and target.endswith("/icp-bench"):
                        link = project / step["with"]["path"]
                        if not link.exists():
                            link.symlink_to(REPO, target_is_directory=True)
                        print(f"docs-check: {where}: {link} -> this clone")
                    else:
                        print(f"docs-check: {where}: nothing to do here")
                    continue
                cwd = project / step.get("working-directory", ".")
                print(f"docs-check: running {where} in {cwd}", flush=True)
                status, _ = run_block(where, "sh", step["run"], cwd, dict(env, CI="true"), None)
                self.counts["ran" if status == 0 else "failed"] += 1
                if status != 0:
                    return False
        return True


def main():
    readme = REPO / "README.md"
    pages = [readme, REPO / "eval/README.md", REPO / "datasets/README.md"]
    broken = [b for page in pages + sorted((REPO / "docs").glob("*.md")) for b in broken_links(page)]
    if broken:
        sys.exit("docs-check: broken links\n" + "\n".join(broken))
    readme_blocks = blocks(readme)
    check_test_command(readme_blocks)
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="docs-check-"))
    runner = Runner(scratch)
    ok = runner.file(readme, REPO) is not None
    # The README installed icp-eval: its --help may point to docs/ pages, which must exist.
    broken = broken_help_links(runner.env) if ok else []
    if broken:
        print("docs-check: " + "\n".join(broken), file=sys.stderr)
        ok = False
    # The docs' readers have the README's venv active.
    venv = REPO / ".venv"
    runner.env["PATH"] = f"{venv / 'bin'}:{runner.env['PATH']}"
    runner.env["VIRTUAL_ENV"] = str(venv)
    docs = sorted((REPO / "docs").glob("*.md"))
    for doc in docs if ok else []:
        home = scratch / doc.stem
        home.mkdir()
        (home / "icp-bench").symlink_to(REPO, target_is_directory=True)
        end = runner.file(doc, home)
        ok = end is not None
        if ok and doc.name == "gate.md":
            ok = runner.workflow(REPO / "docs/ci/github-actions.yml", end)
        if not ok:
            break
    c = runner.counts
    print(f"docs-check: {c['ran']} passed, {c['failed']} failed, {c['skipped']} skipped")
    if ok:
        shutil.rmtree(scratch, ignore_errors=True)
    else:
        print(f"docs-check: the scratch folder is kept: {scratch}", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
