"""One exception type for every user-facing failure: a one-line message naming the file and the problem."""


class DragMeshError(Exception):
    """Bad input or impossible configuration. The CLI prints ``error: <message>`` and exits with status 2."""

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))  # always one line


class FolderBusy(DragMeshError):
    """Another process holds the folder's writer lock."""


class NotWritable(DragMeshError):
    """The folder cannot be written (read-only storage, no permission)."""


class NotSaved(DragMeshError):
    """A result (``what``) was computed but could not be saved: ``result`` holds it, so the command can print it
    whole or save it elsewhere, and ``reason`` says why (one line naming the folder or file)."""

    def __init__(self, what: str, reason: str, result: dict):
        super().__init__(f"{what} was not saved: {reason}")
        self.reason, self.result = " ".join(reason.split()), result
