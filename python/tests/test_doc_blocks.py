"""Every ```python block of the book (docs/src/**/*.md; a file a chapter {{#include}}s is read
as itself, e.g. python/README.md for python-api.md) and of the README runs against the
installed package, so that a renamed function or argument in the docs fails here naming the
file and the line.

A file's blocks run in order in one namespace (a later block may use an earlier one's names),
in a fresh temporary folder that holds what the docs tell the reader to run from: a copy of the
checkout's ``scenes/`` (python.md: "run it from the checkout's root"). A block of ``>>>`` lines
is a REPL transcript: run by doctest in that namespace, its printed output and exception lines
compared exactly. A block marked ```python,ignore-check (it needs what a test cannot provide,
e.g. petsc4py under mpirun) is only compiled. Shell and output blocks are not python.
"""

import doctest
import shutil
import traceback
from pathlib import Path

import pytest

from conftest import REPO, optional_import

# The Markdown files whose python blocks are run: the READMEs and every chapter of the book.
DOC_FILES = sorted(
    {"README.md", "python/README.md", "scenes/README.md"}
    | {str(p.relative_to(REPO)) for p in (REPO / "docs" / "src").rglob("*.md")}
)

# Files whose blocks import an optional package (installed by CI before pytest).
NEEDS = {"docs/src/python.md": ["matplotlib"]}


def fenced_blocks(text):
    """Every fenced block of a Markdown text as (1-based line of the opening fence, the info
    string's words, the content with the fence's indentation removed)."""
    blocks, current = [], None
    for i, line in enumerate(text.splitlines()):
        stripped = line.lstrip(" ")
        indent = len(line) - len(stripped)
        char = stripped[:1] if stripped[:1] in ("`", "~") else ""
        run = len(stripped) - len(stripped.lstrip(char)) if char else 0
        if current is None:
            # A backtick fence's info string holds no backtick (CommonMark): a line such as
            # ```` ```toml ```` is inline code, not a fence.
            if run >= 3 and not (char == "`" and "`" in stripped[run:]):
                words = stripped[run:].replace(",", " ").split()
                current = (i + 1, words, char, run, indent, [])
            continue
        start, words, fence, length, fence_indent, lines = current
        if char == fence and run >= length and not stripped[run:].strip():
            blocks.append((start, words, "\n".join(lines) + "\n"))
            current = None
        else:
            lines.append(line[min(indent, fence_indent) :])
    return blocks


def python_blocks(doc):
    """The ```python blocks of one file, as (line, words, text)."""
    text = (REPO / doc).read_text(encoding="utf-8")
    return [b for b in fenced_blocks(text) if b[1][:1] == ["python"]]


def files_with_python():
    return [doc for doc in DOC_FILES if python_blocks(doc)]


def test_the_walk_finds_the_documented_blocks():
    """The walk must see the blocks, not an empty list that passes: the README's, the Python
    chapter's and the API page's (python/README.md) are among them."""
    found = files_with_python()
    for doc in ("README.md", "docs/src/python.md", "python/README.md"):
        assert doc in found, f"no python block found in {doc}: {found}"


def run_block(doc, line, text, namespace):
    """Runs one block in ``namespace``: as code (its tracebacks give the Markdown file's own
    line numbers), or as a doctest when it is a ``>>>`` transcript."""
    if text.lstrip().startswith(">>>"):
        test = doctest.DocTestParser().get_doctest(text, namespace, f"{doc}:{line}", doc, line)
        report = []
        runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
        result = runner.run(test, out=report.append, clear_globs=False)
        namespace.update(test.globs)
        assert result.failed == 0, f"{doc}:{line}: the transcript differs:\n" + "".join(report)
        return
    code = compile("\n" * line + text, str(REPO / doc), "exec")
    exec(code, namespace)


@pytest.mark.parametrize("doc", files_with_python())
def test_python_blocks_run(doc, tmp_path, monkeypatch):
    for module in NEEDS.get(doc, []):
        optional_import(module, f"{doc} imports {module}")
    monkeypatch.setenv("MPLBACKEND", "Agg")  # plots are saved, never shown
    shutil.copytree(REPO / "scenes", tmp_path / "scenes")
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__main__"}
    for line, words, text in python_blocks(doc):
        if "ignore-check" in words:
            compile(text, f"{doc}:{line}", "exec")
            continue
        run_block(doc, line, text, namespace)


def test_a_renamed_function_fails_at_its_line():
    """A block that calls a function the package lacks fails with the Markdown file's own line
    in its traceback (a copy of the README's block, one name changed)."""
    line, _, text = python_blocks("README.md")[0]
    assert "tetfem.solve_static(" in text
    broken = text.replace("tetfem.solve_static(", "tetfem.solve_statics(")
    with pytest.raises(AttributeError, match="solve_statics") as info:
        run_block("README.md", line, broken, {"__name__": "__main__"})
    frame = traceback.extract_tb(info.tb)[-1]
    offset = next(i for i, l in enumerate(text.splitlines()) if "solve_static(" in l)
    assert (frame.filename, frame.lineno) == (str(REPO / "README.md"), line + 1 + offset)


def test_a_transcript_with_another_message_fails(tmp_path, monkeypatch):
    """A ``>>>`` block whose shown error differs from the one raised fails (a copy of
    python/README.md's transcript, its message changed), so the transcript is compared."""
    monkeypatch.chdir(tmp_path)
    blocks = python_blocks("python/README.md")
    namespace = {"__name__": "__main__"}
    run_block("python/README.md", blocks[0][0], blocks[0][2], namespace)
    line, _, text = next(b for b in blocks if b[2].lstrip().startswith(">>>"))
    run_block("python/README.md", line, text, namespace)
    broken = text.replace("'explicit'", "'rk4'")
    assert broken != text
    with pytest.raises(AssertionError, match="the transcript differs"):
        run_block("python/README.md", line, broken, namespace)


def test_fences_are_read_as_commonmark_reads_them():
    """A backtick run with a backtick after it is inline code, an indented fence's indentation
    is removed from its lines, ``~~~`` fences count, the info string is split at commas."""
    text = "a\n```` ```python ```` is inline\n  ```python,ignore-check\n  x = 1\n  ```\n~~~sh\ny\n~~~\n"
    assert fenced_blocks(text) == [(3, ["python", "ignore-check"], "x = 1\n"), (6, ["sh"], "y\n")]
