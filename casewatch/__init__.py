"""casewatch: monitor automated-driving channels against a GSN safety case compiled to STL."""

__version__ = "0.1.0"
