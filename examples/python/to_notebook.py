"""Writes a notebook-style script's `.ipynb`: the script is the source, the notebook its copy.

Cells of the script start at lines `# %%` (code) and `# %% [markdown]` (markdown, each line's
leading `# ` removed). The notebook is written without outputs, so `jupyter nbconvert --execute`
fills them and the file in the repository stays a pure function of the script.

Run: python examples/python/to_notebook.py [SCRIPT ...]  (default: curved_bracket.py beside it)
     python examples/python/to_notebook.py --check   (CI: exit 1 if a notebook is not the script's copy)
"""

import json
import pathlib
import re
import sys

HERE = pathlib.Path(__file__).resolve().parent


def cells(script: str) -> list:
    """The notebook cells of a script, in order; text before the first `# %%` is dropped."""
    out = []
    # A cell marker is a whole line, so `# %%` quoted inside a cell's text does not split it.
    for block in re.split(r"^# %%", script, flags=re.MULTILINE)[1:]:
        header, _, body = block.partition("\n")
        lines = body.strip("\n").split("\n")
        if header.strip() == "[markdown]":
            text = [line[2:] if line.startswith("# ") else line.lstrip("#") for line in lines]
            out.append({"cell_type": "markdown", "metadata": {}, "source": text})
        else:
            out.append({"cell_type": "code", "execution_count": None, "metadata": {}, "outputs": [], "source": lines})
    for cell in out:  # nbformat keeps each line's newline but the last
        cell["source"] = [line + "\n" for line in cell["source"][:-1]] + cell["source"][-1:]
    return out


def notebook(script: str) -> str:
    nb = {
        "cells": cells(script),
        "metadata": {
            "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
            "language_info": {"name": "python"},
        },
        "nbformat": 4,
        "nbformat_minor": 5,
    }
    for number, cell in enumerate(nb["cells"]):
        cell["id"] = f"cell-{number}"  # stable ids: the file changes only when the script does
    return json.dumps(nb, indent=1, ensure_ascii=False) + "\n"


def main(args: list) -> int:
    check = "--check" in args
    scripts = [pathlib.Path(a) for a in args if a != "--check"] or [HERE / "curved_bracket.py"]
    stale = []
    for script in scripts:
        target = script.with_suffix(".ipynb")
        text = notebook(script.read_text(encoding="utf-8"))
        if check:
            if not target.exists() or target.read_text(encoding="utf-8") != text:
                stale.append(target)
        else:
            target.write_text(text, encoding="utf-8")
            print(f"wrote {target}")
    for target in stale:
        print(f"{target} is not the copy of its script: run python {pathlib.Path(__file__).name}", file=sys.stderr)
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
