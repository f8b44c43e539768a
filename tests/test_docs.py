"""The generated parts of the docs match the code they are generated from."""
import importlib.util
from pathlib import Path

from groundplane.options import markdown_table
from optimise.cli import eval_option_groups

ROOT = Path(__file__).resolve().parents[1]


def _make_options():
    spec = importlib.util.spec_from_file_location("make_options", ROOT / "docs" / "make_options.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_options_table_in_the_docs_is_what_the_settings_dataclasses_say():
    make = _make_options()
    text = (ROOT / "docs" / "commands.md").read_text()
    assert make.with_block(text) == text, "docs/commands.md's options table is stale: run python docs/make_options.py"


def test_the_options_table_changes_with_a_default_and_lists_a_shared_flag_once():
    from solvers.engines.base import SolveSettings

    table = markdown_table(eval_option_groups())
    assert table.count("`--mesh SPACING`") == 1  # the plate model's, shared by both engines
    assert "| `--workers` | 2 |" in table

    from dataclasses import dataclass

    from groundplane.options import option

    @dataclass(frozen=True)
    class Moved(SolveSettings):
        workers: int = option(7, "parallel solver processes")

    assert "| `--workers` | 7 |" in markdown_table([("solver", Moved)])
