"""The README's Python example runs as written (its output directory moved to a temporary one)."""

import pathlib
import re

from conftest import REPO


def test_the_readme_example_runs(tmp_path, capsys):
    text = (REPO / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    example = next(b for b in blocks if "import icp_bench" in b)
    assert '"results/python-ra"' in example
    exec(compile(example.replace('"results/python-ra"', repr(str(tmp_path / "ra"))),
                 "README.md", "exec"), {})
    printed = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in printed[-3:]] == ["H_ICP", "HD_ICP", "RA_ICP"]
    assert pathlib.Path(tmp_path / "ra" / "trajectory_RA_ICP.tum").exists()
