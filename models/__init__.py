"""The notes' models (MJCF), paired with equations/<name>.py by file stem: package data of `lagrange_xval`."""
