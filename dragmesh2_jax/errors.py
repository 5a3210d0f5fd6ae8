"""One exception type for every user-facing failure: a one-line message naming the file and the problem."""


class DragMeshError(Exception):
    """Bad input or impossible configuration. The CLI prints ``error: <message>`` and exits with status 2."""

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))  # always one line
