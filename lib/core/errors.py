"""Exceptions shared by the library and the command-line tools."""


class InputError(ValueError):
    """Bad input data or a failed estimate.

    The command-line frame turns it into exit code 1 and one line
    ``Error: <tool>: <message>`` on stderr, so the message must say what is
    wrong and what was expected, in one sentence, without a traceback.
    """
