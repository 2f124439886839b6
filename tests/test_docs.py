"""The manuals' examples run as written, and what the README and the docs pages claim holds."""

import doctest
import re
import unicodedata
from pathlib import Path

import gymnasium as gym
import pytest

import mobile_envs
import mobile_envs.catalogue
import mobile_envs.envs.path_following
from mobile_envs.robots import MODELS

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS = ROOT / "docs"
#: The front page's budget: results, speed tables and their history belong in docs/.
README_MAX_LINES = 200


def fenced_blocks(text: str, language: str) -> list[str]:
    """The bodies of the ```language blocks of a Markdown text, in order."""
    return re.findall(rf"^```{language}\n(.*?)^```$", text, flags=re.MULTILINE | re.DOTALL)


def section(text: str, heading: str) -> str:
    """The text under a ``## heading`` of a Markdown text, up to the next such heading."""
    pattern = rf"^## {re.escape(heading)}\n(.*?)(?=^## |\Z)"
    match = re.search(pattern, text, re.MULTILINE | re.DOTALL)
    assert match, f"README.md has no section '## {heading}'"
    return match.group(1)


def slug(heading: str) -> str:
    """The anchor Python-Markdown's toc extension (mkdocs) gives a heading."""
    text = unicodedata.normalize("NFKD", heading).encode("ascii", "ignore").decode("ascii")
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def anchors(markdown_file: Path) -> set[str]:
    text = markdown_file.read_text()
    text = re.sub(r"^```.*?^```$", "", text, flags=re.MULTILINE | re.DOTALL)
    return {slug(heading) for heading in re.findall(r"^#+ (.+)$", text, flags=re.MULTILINE)}


@pytest.mark.parametrize("module", [mobile_envs.envs.path_following, mobile_envs.catalogue])
def test_docstring_examples_run(module):
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert tried > 0 and failures == 0


def test_readme_test_command_is_the_one_ci_runs():
    """.ci/run installs and tests exactly as the README's test command says, line for line."""
    tests = section(README.read_text(), "Install").split("**Tests**", 1)[1]
    command = fenced_blocks(tests, "bash")[0].strip()
    steps = command.split(" && ")
    assert steps[:2] == ["python3 -m venv .venv", ". .venv/bin/activate"]
    ci = (ROOT / ".ci" / "run").read_text()
    ci_block = ci.split("# --- the README's test command", 1)[1].split("\n# ---", 1)[0]
    ci_steps = [
        line.strip()
        for line in ci_block.splitlines()[1:]
        if line.strip() and line.strip() != "start_ray"
    ]
    assert ci_steps == steps[2:]


def test_readme_links_and_images_point_at_files_and_headings_that_exist():
    links = re.findall(r"\]\(([^)\s]+)\)", README.read_text())
    local = [link for link in links if not re.match(r"[a-z]+://", link)]
    assert len(local) > 10  # the gallery GIF and the links to the docs pages
    for link in local:
        path, _, anchor = link.partition("#")
        target = ROOT / path
        assert target.is_file(), f"README.md links to {path}, which does not exist"
        if anchor:
            assert anchor in anchors(target), f"README.md links to {link}: no such heading"


def test_readme_stays_a_front_page():
    lines = len(README.read_text().splitlines())
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines: move details to docs/"


def test_every_id_the_readme_and_docs_name_is_registered():
    pages = [README, *sorted(DOCS.rglob("*.md"))]
    named = {
        (page.relative_to(ROOT), env_id)
        for page in pages
        for env_id in re.findall(r"mobile_envs/[A-Za-z]+(?:-[A-Za-z]+)*-v\d+", page.read_text())
    }
    assert len(named) > 20
    unknown = sorted(f"{page}: {env_id}" for page, env_id in named if env_id not in gym.registry)
    assert not unknown, unknown


def test_the_readme_id_grammar_builds_registered_ids():
    """Every model and path set the README's id table names makes an id with every suffix it
    promises: -Beacons on every set but Random, -Odometry and -OdometryBeacons for the models
    with wheel encoders."""
    table = section(README.read_text(), "Environment ids")

    def names(part: str) -> list[str]:
        row = re.search(rf"^\| `{re.escape(part)}` \|(.*)\|$", table, re.MULTILINE)
        assert row, f"the id table has no row for {part}"
        return re.findall(r"`-?(\w+)`", row.group(1))

    models, path_sets = names("<Model>"), names("<PathSet>")
    assert set(names("-<Localization>")) >= {"Odometry", "OdometryBeacons", "Beacons"}
    assert len(models) >= 5 and "Random" in path_sets
    for model in models:
        wheeled = MODELS[mobile_envs.MODEL_IDS[model]].has_encoders
        for path_set in path_sets:
            suffixes = [""]
            if path_set != "Random":
                suffixes += ["-Beacons"] + (["-Odometry", "-OdometryBeacons"] if wheeled else [])
            for suffix in suffixes:
                assert f"mobile_envs/{model}-{path_set}{suffix}-v0" in gym.registry


def test_readme_first_episode_runs(capsys):
    for block in fenced_blocks(section(README.read_text(), "A first episode"), "python"):
        exec(compile(block, "README.md", "exec"), {})
    assert "completion_rate" in capsys.readouterr().out
