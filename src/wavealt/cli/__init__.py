"""The ``wavealt`` command line: thin; parses, calls the library, prints.

``pipeline`` holds the commands of the pipeline (simulate, figures, deglint, train,
evaluate, reproduce), ``altitude`` the altimeter's, ``parse`` the parsing they share.

Errors from the library (``ValueError``, ``FileNotFoundError``) become one line on stderr
and exit code 2, never a traceback.
"""

from __future__ import annotations

import sys

import click

from wavealt import __version__
from wavealt.cli.altitude import altitude
from wavealt.cli.pipeline import COMMANDS as PIPELINE_COMMANDS


def _versions() -> str:
    # deferred, as every stage in the commands: --version alone pays for numpy and torch
    import numpy as np

    try:
        import torch
        tv = torch.__version__
    except Exception:  # torch is optional for --version; report why it is missing
        tv = "not importable"
    return f"wavealt {__version__}\nnumpy {np.__version__}\ntorch {tv}\npython {sys.version.split()[0]}"


def _print_version(ctx: click.Context, _param: click.Parameter, value: bool) -> None:
    if value and not ctx.resilient_parsing:
        click.echo(_versions())
        ctx.exit()


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True,
              callback=_print_version, help="Print wavealt, NumPy and torch versions.")
def cli() -> None:
    """Camera altimetry over the sea, through sun glint."""


for _command in (*PIPELINE_COMMANDS, altitude):
    cli.add_command(_command)


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the CLI, turning library errors into one line and exit code 2."""
    try:
        cli.main(args=argv, prog_name="wavealt", standalone_mode=False)
    except click.exceptions.Abort:
        click.echo("wavealt: aborted", err=True)
        sys.exit(130)
    except click.ClickException as exc:
        click.echo(f"wavealt: error: {exc.format_message()}", err=True)
        sys.exit(exc.exit_code)
    except (ValueError, FileNotFoundError, NotADirectoryError, IsADirectoryError) as exc:
        click.echo(f"wavealt: error: {exc}", err=True)
        sys.exit(2)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)


if __name__ == "__main__":  # pragma: no cover
    main()
