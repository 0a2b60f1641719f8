"""The `jamflow-cli` directive: every command's `--help`, taken from the built binary.

The commands are found in the binary's own help: the top level lists them as `jamflow NAME`
usage lines, and a command with subcommands (CLI11) lists them under "Subcommands:". Each gets
a section titled by its command line, holding its `--help` text as it prints it. The binary is
$JAMFLOW_BIN (docs/conf.py sets it); a binary that is missing or a help that fails is an error,
so the docs never show a stale or pasted reference.
"""
import os
import re
import subprocess

from docutils import nodes
from sphinx.util.docutils import SphinxDirective


def _help(binary, words):
    proc = subprocess.run([binary, *words, "--help"], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "COLUMNS": "100"})
    if proc.returncode != 0:
        raise RuntimeError(f"`jamflow {' '.join(words + ['--help'])}` exited with "
                           f"{proc.returncode}: {proc.stderr.strip()}")
    return proc.stdout.rstrip() + "\n"


def _top_commands(text):
    names = []
    for line in text.splitlines():
        m = re.match(r"\s+(?:mpirun .*?)?jamflow ([a-z][a-z-]*)\b", line)
        if m and m.group(1) not in names:
            names.append(m.group(1))
    return names


def _subcommands(text):
    names, inside = [], False
    for line in text.splitlines():
        if line.startswith("Subcommands:"):
            inside = True
            continue
        if inside:
            m = re.match(r"\s{2}([a-z][a-z-]*)\s", line + " ")
            if m:
                names.append(m.group(1))
            elif line.strip() and not line.startswith(" "):
                inside = False
    return names


def command_helps(binary):
    """[(words, help text)] for `jamflow` and every command and subcommand, in help order."""
    top = _help(binary, [])
    out = [([], top)]
    pending = [[name] for name in _top_commands(top)]
    while pending:
        words = pending.pop(0)
        text = _help(binary, words)
        out.append((words, text))
        pending[0:0] = [words + [sub] for sub in _subcommands(text)]
    return out


class JamflowCli(SphinxDirective):
    has_content = False

    def run(self):
        binary = os.environ.get("JAMFLOW_BIN", "")
        if not binary or not os.access(binary, os.X_OK):
            raise self.error(f"jamflow-cli: no jamflow binary at JAMFLOW_BIN={binary!r} "
                             "(build it first, or set JAMFLOW_BIN)")
        self.env.note_dependency(os.path.abspath(binary))
        try:
            helps = command_helps(binary)
        except (OSError, RuntimeError, subprocess.TimeoutExpired) as e:
            raise self.error(f"jamflow-cli: {e}")
        result = []
        for words, text in helps:
            title = " ".join(["jamflow", *words])
            section = nodes.section(ids=[nodes.make_id(title)], names=[nodes.fully_normalize_name(title)])
            section += nodes.title(title, "", nodes.literal(title, title))
            section += nodes.literal_block(text, text, language="text")
            self.state.document.note_implicit_target(section, section)
            result.append(section)
        return result


def setup(app):
    app.add_directive("jamflow-cli", JamflowCli)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
