"""The CLI called in-process, as the CLI tests call it."""

from qmesh.cli import main


def run(capsys, *argv):
    """main(argv) with every argument as text; returns (exit code, stdout, stderr)."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err
