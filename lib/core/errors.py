"""Exceptions shared by the library and the command-line tools."""


class InputError(ValueError):
    """Bad input data or a failed estimate.

    The command-line frame turns it into exit code 1 and one line
    ``Error: <tool>: <message>`` on stderr, so the message must say what is
    wrong and what was expected, in one sentence, without a traceback.
    """


class OutputError(InputError):
    """An output could not be written (a full disk, a closed stream, a folder that is not there).

    Exit code 1 and one line, like :class:`InputError`; nothing the output replaces is touched.
    """


class SameFileError(InputError):
    """An output names the same file as an input or as another output (compared by device and inode).

    The command-line frame refuses it as a usage error: exit code 2 and one line, before anything is replaced.
    """
