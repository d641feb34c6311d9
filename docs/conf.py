"""Sphinx configuration of the granalytics documentation site (``make docs``).

Two parts of the site are written here at every build, from the sources, so that they cannot
drift from them (both folders are ignored by git):

- ``api/``: the API reference, one autosummary entry per public name, that is per name in
  ``granalytics.__all__`` and ``sim.__all__``, grouped by the topics of ``granalytics.__doc__``;
- ``results/``: ``results.md`` split into a summary page and one page per numbered section.
"""

import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))  # the checkout's packages, even where they are not installed

import granalytics  # noqa: E402
import sim  # noqa: E402

project = "granalytics"
author = "granalytics developers"
copyright = "granalytics developers, MIT licence"
release = version = granalytics.__version__

extensions = [
    "myst_nb",  # Markdown pages (myst-parser) and executed notebooks
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx.ext.mathjax",
]

# .rst first: autosummary writes its stubs (reStructuredText) with the first suffix
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
exclude_patterns = [
    "_build", "_templates", "**.ipynb_checkpoints", "figures/**",
    "results.md",  # built as results/ (split by section, below)
]
suppress_warnings = [
    # pages keep their own heading levels (a page split out of results.md starts at its "##")
    "myst.header",
]

# --- Markdown (myst-parser) ---------------------------------------------------------------------
myst_heading_anchors = 3  # [text](physics.md#liquid-bridges)
myst_enable_extensions = ["colon_fence", "deflist"]

# --- notebooks (myst-nb): executed at build time on the bundled data, about a minute in all ----
nb_execution_mode = "cache"
nb_execution_cache_path = str(ROOT / "build" / "docs" / "jupyter_cache")
nb_execution_timeout = 900
nb_execution_raise_on_error = True
nb_execution_in_temp = True  # the notebooks' own output files go to a temporary folder
nb_merge_streams = True
# The notebooks' kernels talk to the build over CurveZMQ-encrypted sockets when the kernel says it
# can (ipykernel warns once per notebook about unencrypted TCP; jupyter-cache gives no way to pass
# the kernel manager's configuration, so the default of its encryption policy is set here).
import zmq  # noqa: E402
from jupyter_client.manager import KernelManager  # noqa: E402

if zmq.has("curve"):
    KernelManager.transport_encryption.default_value = "auto"

# --- API reference ------------------------------------------------------------------------------
templates_path = ["_templates"]  # autosummary/class.rst: a class's methods and attributes on its page
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": False}
autodoc_typehints = "none"  # numpydoc's Parameters sections say the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# --- HTML ---------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_static_path = ["_static"]
html_css_files = ["granalytics.css"]  # code lines wrap, wide tables scroll in place
html_title = f"granalytics {version}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "navbar_align": "left",
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_show_sourcelink = False
html_last_updated_fmt = None


# --- generated pages ----------------------------------------------------------------------------
def _topics(doc):
    """(topic, [names]) of every ``- topic: ... :func:`name` ...`` bullet of a package docstring."""
    topics = []
    for bullet in re.findall(r"^- (.+?)(?=^- |^\S|\Z)", doc, flags=re.M | re.S):
        title = bullet.split(":", 1)[0].strip()
        names = re.findall(r":(?:func|class|data|mod):`~?([\w.]+)`", bullet)
        topics.append((title[:1].upper() + title[1:], names))
    return topics


def _autosummary(package, names):
    lines = [".. autosummary::", "   :toctree: generated", "   :nosignatures:", ""]
    return lines + [f"   {package}.{name}" for name in names] + [""]


def write_api(folder):
    """``api/index.rst``: every name of ``granalytics.__all__`` and ``sim.__all__``, each once."""
    folder.mkdir(exist_ok=True)
    exported = [n for n in granalytics.__all__]
    done, out = set(), []
    out += ["API reference", "=============", "",
            f"Every public name of ``granalytics`` ({len(granalytics.__all__)} in ``granalytics.__all__``) and of",
            f"``sim`` ({len(sim.__all__)} in ``sim.__all__``), grouped by task. Import them from the package",
            "(``import granalytics as ga; ga.identify(...)``); the modules that define them are internal and move.",
            "SI units throughout; angles are in degrees only where a name says ``_deg``.", ""]
    out += ["granalytics", "-----------", ""]
    for title, names in _topics(granalytics.__doc__):
        names = [n.removeprefix("granalytics.") for n in names]
        names = [n for n in dict.fromkeys(names) if n in exported and n not in done]
        if names:
            out += [title, "~" * len(title), ""] + _autosummary("granalytics", names)
            done.update(names)
    rest = [n for n in exported if n not in done and n != "__version__"]
    if rest:
        title = "Further public names and modules"
        out += [title, "~" * len(title), ""] + _autosummary("granalytics", rest)
    if "__version__" in exported:
        out += ["``granalytics.__version__``", f"   the version string (``{granalytics.__version__!r}``)", ""]
    out += ["sim (the simulator)", "-------------------", "",
            "The simulator is used from its command line (``python -m sim``, :doc:`../simulator`); its",
            "Python API is the force laws and the parameters.", ""]
    out += _autosummary("sim", list(sim.__all__))
    text = "\n".join(out)
    path = folder / "index.rst"
    if not path.exists() or path.read_text() != text:
        path.write_text(text)
    listed = {f"{line.strip()}.rst" for line in out if line.startswith("   granalytics.") or line.startswith("   sim.")}
    for stub in (folder / "generated").glob("*.rst"):  # a renamed or removed name's page from an earlier build
        if stub.name not in listed:
            stub.unlink()


_FIGURE_LINK = re.compile(r"(?<!!)\[([^\]]+)\]\((\.\./figures/[^)]+\.png)\)")


def _figures_inline(body):
    """A paragraph that links to figures is followed by the figures themselves (a link in running
    text stays a link; the reader should not have to download a figure to see it)."""
    shown = set(re.findall(r"!\[[^\]]*\]\(([^)]+)\)", body))
    out = []
    for block in re.split(r"(\n\s*\n)", body):
        out.append(block)
        if block.lstrip().startswith(("|", "```", "    ")):
            continue  # tables and code keep their links
        figures = [(label, path) for label, path in _FIGURE_LINK.findall(block) if path not in shown]
        if figures:
            shown.update(path for _, path in figures)
            out.append("\n\n" + "\n".join(f"![{label}]({path})" for label, path in figures))
    return "".join(out)


def write_results(folder, source):
    """``results/``: the summary of ``results.md``, then one page per ``## `` section."""
    folder.mkdir(exist_ok=True)
    text = source.read_text()
    # a link to a file outside docs/ (../CHANGELOG.md) is no page of the site: its name stays, as code
    text = re.sub(r"\[([^\]]+)\]\(\.\./[^)]*\)", lambda m: m[1] if m[1].startswith("`") else f"`{m[1]}`", text)
    # links and images are relative to docs/; the pages are one folder down
    text = re.sub(r"\]\((?!https?:|#|/)", "](../", text)
    head, *sections = re.split(r"^(?=## )", text, flags=re.M)
    summary, sections = (sections[0], sections[1:]) if sections[0].startswith("## Summary") else ("", sections)
    pages = {}
    for number, section in enumerate(sections):
        title = section.splitlines()[0][3:].strip()
        words = re.sub(r"[^a-z0-9]+", " ", re.sub(r"^\d+\.\s*", "", title).lower()).split()
        slug = "-".join(words[:5])
        name = f"{number:02d}-{slug}"
        body = re.sub(r"^#(#+ )", r"\1", section, flags=re.M)  # one level up: "## 2. ..." is the title
        pages[name] = _figures_inline(body)
    index = head + summary + "\n## The studies\n\nOne page per study, each with the commands that remake its numbers.\n\n"
    index += "```{toctree}\n:maxdepth: 1\n\n" + "\n".join(pages) + "\n```\n"
    pages["index"] = index
    for name, body in pages.items():
        path = folder / f"{name}.md"
        if not path.exists() or path.read_text() != body:
            path.write_text(body)
    for stale in folder.glob("*.md"):  # a section renamed or removed
        if stale.stem not in pages:
            stale.unlink()


_LITERAL = re.compile(r"(``.+?``|`[^`]+`)")
_BARS = re.compile(r"(?<![\w|\\])\|(?=\S)([^|\n]{1,40}?)(?<=\S)\|(?![\w|])")


def escape_absolute_values(app, what, name, obj, options, lines):
    """``|x|`` in a docstring is an absolute value, not a reStructuredText substitution."""
    for i, line in enumerate(lines):
        parts = _LITERAL.split(line)  # odd parts are literals and roles' targets: left as they are
        lines[i] = "".join(p if k % 2 else _BARS.sub(r"\\|\1\\|", p) for k, p in enumerate(parts))


_COMMENTED = re.compile(r"((?:^#:.*\n)+)^([A-Z][A-Z0-9_]*)\s*(?::[^=\n]*)?=", re.M)


def _constant_comments():
    """NAME -> the ``#:`` comment above its definition, over the packages' sources (a constant
    re-exported from the package has no comment where autodoc looks for it)."""
    found = {}
    for path in sorted([*ROOT.glob("granalytics/**/*.py"), *ROOT.glob("sim/**/*.py")]):
        for comment, name in _COMMENTED.findall(path.read_text()):
            found.setdefault(name, [line[2:].strip() for line in comment.splitlines()])
    return found


_CONSTANTS = _constant_comments()


def document_constants(app, what, name, obj, options, lines):
    """A public constant's page gets its ``#:`` comment, not the docstring of its type (a float's,
    a tuple's "Built-in immutable sequence.", or nothing)."""
    short = name.rsplit(".", 1)[-1]
    if what not in ("data", "attribute") or short not in _CONSTANTS:
        return
    own = "\n".join(lines).strip()
    if own and own != (type(obj).__doc__ or "").strip():
        return  # a docstring of its own
    lines[:] = [" ".join(_CONSTANTS[short])]
    if len(repr(obj)) < 200:
        lines += ["", f"Value: ``{obj!r}``"]


def write_pages(app, config):
    write_api(DOCS / "api")
    write_results(DOCS / "results", DOCS / "results.md")


def setup(app):
    app.connect("config-inited", write_pages)  # before Sphinx looks for the source files
    app.connect("autodoc-process-docstring", escape_absolute_values, priority=400)
    app.connect("autodoc-process-docstring", document_constants, priority=300)
