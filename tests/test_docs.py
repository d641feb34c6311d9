"""The documentation site (`make docs`, docs/conf.py): the API reference covers every public name,
the results pages keep every line of docs/results.md, and the site is built with warnings as errors
(CI builds the whole site after the tests: .ci/run)."""

import importlib.util
import os
import re
import subprocess
from pathlib import Path

import pytest

import granalytics
import sim

ROOT = Path(__file__).parents[1]


@pytest.fixture(scope="module")
def conf():
    spec = importlib.util.spec_from_file_location("docs_conf", ROOT / "docs" / "conf.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # writes nothing: the pages are written when a build starts
    return module


def test_the_api_reference_lists_every_public_name_once(conf, tmp_path):
    conf.write_api(tmp_path)
    text = (tmp_path / "index.rst").read_text()
    listed = re.findall(r"^   ((?:granalytics|sim)\.\w+)$", text, flags=re.M)
    assert len(listed) == len(set(listed))
    exported = {f"granalytics.{n}" for n in granalytics.__all__ if n != "__version__"} | {f"sim.{n}" for n in sim.__all__}
    assert set(listed) == exported
    assert "granalytics.__version__" in text


def test_the_results_pages_keep_every_line_of_results_md(conf, tmp_path):
    conf.write_results(tmp_path, ROOT / "docs" / "results.md")
    pages = {p.stem: p.read_text() for p in tmp_path.glob("*.md")}
    source = (ROOT / "docs" / "results.md").read_text()
    numbered = re.findall(r"^## (\d+)\. ", source, flags=re.M)
    assert len(pages) >= len(numbered) + 1 and "index" in pages
    def plain(text):  # the text is the same, up to heading levels, links and code marks
        return re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text).replace("`", "")

    built = plain("\n".join(pages.values()))
    for line in source.splitlines():
        assert plain(line.lstrip("#")).strip() in built, line
    for name in pages:  # every page is in the summary's table of contents
        assert name == "index" or f"\n{name}\n" in pages["index"]


def test_make_docs_builds_the_site_the_readme_opens_with_warnings_as_errors():
    plan = subprocess.run(["make", "-n", "-o", ".venv/.installed", "-o", ".venv/.installed-docs", "docs"],
                          cwd=ROOT, capture_output=True, text=True, check=True).stdout
    assert "sphinx" in plan and " -W " in plan and "--keep-going" in plan
    command = next(line for line in (ROOT / "README.md").read_text().splitlines() if line.startswith("make docs"))
    opened = Path(re.search(r"open (\S+)", command).group(1))  # the page the README tells a reader to open
    assert opened.name == "index.html" and f" {opened.parent} " in plan.replace("\n", " ")


def test_ci_runs_the_tests_then_builds_the_site(tmp_path):
    log = tmp_path / "make.log"
    fake = tmp_path / "make"
    fake.write_text(f'#!/bin/sh\necho "$@" >> {log}\n')
    fake.chmod(0o755)
    env = {**os.environ, "PATH": f"{tmp_path}{os.pathsep}{os.environ['PATH']}"}
    subprocess.run(["bash", str(ROOT / ".ci" / "run")], env=env, check=True, capture_output=True, timeout=60)
    assert log.read_text().split() == ["test", "docs"]


def test_every_page_of_docs_is_in_the_site():
    """A Markdown page that no table of contents names is unreachable (Sphinx warns, and -W fails)."""
    toctrees = "\n".join(p.read_text() for p in (ROOT / "docs").rglob("*.md")
                         if not p.is_relative_to(ROOT / "docs" / "results"))
    for page in (ROOT / "docs").glob("*.md"):
        if page.name not in ("results.md", "index.md"):  # results.md: built as docs/results/, a page per section
            assert re.search(rf"^(\.\./)?{page.stem}$", toctrees, flags=re.M), page.name
    for notebook in (ROOT / "docs" / "notebooks").glob("*.ipynb"):
        assert f"../notebooks/{notebook.stem}" in toctrees, notebook.name
