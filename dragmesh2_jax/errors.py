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
    """A result was computed but could not be saved: ``result`` holds it, so the command can print it whole."""

    def __init__(self, message: str, result: dict):
        super().__init__(message)
        self.result = result
