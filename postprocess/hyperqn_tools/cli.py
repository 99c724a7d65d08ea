"""The tools' command lines and the project's rule for bad input: a bad argument, or an output path
that cannot be written, is one line naming it, exit code 1, and nothing written. So arguments and
output paths are checked before a tool writes anything, with the helpers here.

    ArgumentParser   argparse's parser whose errors are that one line and exit 1
    positive_int, positive_float
                     argparse types for counts and times that must be > 0
    positive_ints    argparse type for a comma list of counts (rank counts): each > 0
    count            argparse type for a number of things to do that may be 0
    seconds_or_0     argparse type for a time limit where 0 is none
    input_file       argparse type for a file to read: one that exists and can be read
    program          argparse type for a binary or mpiexec: a path or a name on PATH that can be run
    labelled_program argparse type for LABEL=PATH of a binary; labelled_programs for a comma list
                     of them ({label: path})
    fraction         argparse type for a relative tolerance, in [0, 1)
    unwritable_file(path), unwritable_dir(path)
                     why a file or directory could not be written there, or None
    remove_own(directory, names)
                     removes what a tool wrote in its output directory on an earlier run, by
                     name, and nothing else of it
    writing(path)    a context for writing path: on an OSError (a full disk, which the checks
                     cannot see) the file is removed and the OSError names path
"""
import argparse
import contextlib
import math
import os
import shutil


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser, but a bad argument is one line and exit 1 (argparse prints its usage
    and exits 2)."""

    def error(self, message):
        self.exit(1, f"{self.prog}: error: {message}\n")


def whole_number(text, least):
    """argparse's value of a whole number >= least, else an ArgumentTypeError naming it."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < least:
        raise argparse.ArgumentTypeError(f"{text!r}: must be at least {least}")
    return value


def finite_number(text, zero_allowed):
    """argparse's value of a finite number > 0 (>= 0 if zero_allowed); nan and inf refused."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and (value >= 0 if zero_allowed else value > 0)):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number {'>=' if zero_allowed else '>'} 0")
    return value


def positive_int(text):
    return whole_number(text, 1)


def positive_float(text):  # nan and inf too: 'never' is leaving the option out
    return finite_number(text, False)


def positive_ints(text):
    return [positive_int(t) for t in text.split(",")]


def count(text):
    return whole_number(text, 0)


def seconds_or_0(text):
    return finite_number(text, True)


def input_file(text):
    if not os.path.isfile(text):
        raise argparse.ArgumentTypeError(f"{text}: no such file")
    if not os.access(text, os.R_OK):
        raise argparse.ArgumentTypeError(f"{text}: cannot be read")
    return text


def program(text):
    if not shutil.which(text):
        raise argparse.ArgumentTypeError(f"{text}: not an executable file")
    return text


def labelled_program(text):
    label, sep, path = text.partition("=")
    if not (sep and label and path):
        raise argparse.ArgumentTypeError(f"{text!r}: not LABEL=PATH")
    return label, program(path)


def labelled_programs(text):
    return dict(labelled_program(t) for t in text.split(","))


def fraction(text):
    """A relative tolerance (a fraction of a length or displacement): a number in [0, 1); nan, a
    negative number or 1 and above are not (with nan every comparison would fail or pass)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 <= value < 1:  # nan too
        raise argparse.ArgumentTypeError(f"{text!r}: must be a number in [0, 1)")
    return value


def unwritable_dir(path, named=None):
    """Why the directory path could not be made or written in, else None; the message names
    `named` (default: path). Permissions are read with os.access, which root passes: the write
    itself must still catch OSError."""
    named = named or path
    here = os.path.abspath(path)
    while not os.path.exists(here):  # the nearest part that exists: the rest is made in it
        here = os.path.dirname(here)
    if not os.path.isdir(here):
        return f"{named}: not a directory" if here == os.path.abspath(named) else f"{named}: {here} is not a directory"
    if not os.access(here, os.W_OK | os.X_OK):
        return f"{named}: cannot write in {here}"
    return None


def unwritable_file(path, parents=True):
    """Why the file path could not be written, else None (see unwritable_dir); parents=False: its
    directory must exist (a tool that does not make it)."""
    if os.path.isdir(path):
        return f"{path}: is a directory"
    if os.path.exists(path) and not os.access(path, os.W_OK):
        return f"{path}: not writable"
    parent = os.path.dirname(os.path.abspath(path))
    if not parents and not os.path.isdir(parent):
        return f"{path}: no such directory {parent}"
    return unwritable_dir(parent, path)


def remove_own(directory, names):
    """Removes the entries `names` of directory (files or directories a tool writes there, left by
    an earlier run: they would mislead), if there; the rest of directory is the user's and stays."""
    for name in names:
        path = os.path.join(directory, name)
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)
        elif os.path.lexists(path):
            os.remove(path)


class WriteFailed(OSError):
    """An OSError raised by `writing`: its filename is the file that could not be written."""


@contextlib.contextmanager
def writing(path):
    """Writes to path inside the block; an OSError there (a full disk: the checks above cannot see
    one, and an error on closing names no file) removes what was written of path and is raised
    again as a WriteFailed (an OSError) whose filename is path, for a message naming it."""
    try:
        yield
    except OSError as e:
        try:
            if os.path.isfile(path):
                os.remove(path)
        except OSError:
            pass
        raise WriteFailed(e.errno, e.strerror or str(e), str(path)) from None
