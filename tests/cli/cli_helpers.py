"""What the command-line tests share: run a command in process, and list what a folder holds."""

from tendon_id.cli import main


def run(capsys, *argv):
    """``tendon-id ARGV`` in this process: its exit code, standard output and standard error."""
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def files(folder):
    """Every file under ``folder``, as sorted relative POSIX paths."""
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())
