"""The package list, read from the folders: validate/ is `lagrange_xval`, every folder below it with an
`__init__.py` one of its subpackages (pyproject.toml maps the names; this file only finds them, since
setuptools' own `find` cannot rename a folder)."""

from setuptools import find_packages, setup


def packages() -> list[str]:
    return [
        "lagrange_xval",
        *(f"lagrange_xval.{name}" for name in find_packages("validate")),
        "lagrange_xval.equations",
        "lagrange_xval.models",
    ]


if __name__ == "__main__":
    setup(packages=packages())
