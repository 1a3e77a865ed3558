"""Each reader of a model file judged against what the format means (`lagrange-xval audit`).

audit        one file: MuJoCo, Pinocchio and Drake field by field, misreadings named and set aside
twofiles     two files of one robot (a URDF and the MJCF made from it) compared by joint name
importers    the catalogue of known importer behaviours and where each was reported
features     what a file has that a catalogue entry is about; chain: a reading's dynamics in numpy
"""

__all__ = ["audit", "chain", "features", "importers", "twofiles"]
