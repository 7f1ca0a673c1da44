"""casewatch: monitor automated-driving channels against a GSN safety case compiled to STL."""

#: The package's version, written here only: pyproject.toml reads it (`dynamic`), and the
#: evaluator reads the installed metadata built from it (`evaluator.session.casewatch_version`).
__version__ = "0.1.0"
