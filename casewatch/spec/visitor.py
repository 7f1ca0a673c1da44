"""The one base of every pass over a formula's syntax tree.

A pass (writing canonical text, writing rtamt text, the reference evaluator, the numpy engine,
the timing analyses) is a `Visitor` subclass with one method per node class, named
`visit_<Class>` (`visit_Window`, `visit_Sum`, ...). Dispatch is by the node's exact class,
looked up once per pass class, so a pass reads as a table of cases instead of an `isinstance`
chain, and a node class a pass does not handle is an error that names both, never a silent
fall-through.

Adding an operator (docs/architecture.md, "where a new X goes"): add its dataclass to
`casewatch.spec.ast`, then `tests/spec/test_visitor.py` lists every pass that lacks a
`visit_` method for it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar, Generic, TypeVar

from casewatch.spec.ast import FORMULA_TYPES, TERM_TYPES, Node

R = TypeVar("R")

#: Every node class of the syntax tree.
NODE_TYPES: tuple[type, ...] = TERM_TYPES + FORMULA_TYPES


class Visitor(Generic[R]):
    """Dispatches `visit(node, *args)` to `visit_<type(node).__name__>(node, *args)`.

    Extra positional arguments pass through unchanged (the reference evaluator passes the
    sample index). A pass that handles only part of the tree (formulas, not terms) overrides
    `generic_visit` to say what it expects; otherwise a missing case raises `TypeError`."""

    #: node class -> unbound handler, filled per subclass when it is defined
    _handlers: ClassVar[dict[type, Callable[..., Any]]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls._handlers = {
            node_type: handler
            for node_type in NODE_TYPES
            if (handler := getattr(cls, f"visit_{node_type.__name__}", None)) is not None
        }

    def visit(self, node: Node, *args: Any) -> R:
        handler = self._handlers.get(type(node))
        if handler is None:
            return self.generic_visit(node, *args)
        return handler(self, node, *args)

    def generic_visit(self, node: Node, *args: Any) -> R:
        raise TypeError(
            f"{type(self).__name__} has no visit_{type(node).__name__}: not a node it can "
            f"handle: {node!r}"
        )

    @classmethod
    def unhandled(cls) -> list[str]:
        """Node classes this pass has no `visit_` method for (empty for a complete pass)."""
        return [t.__name__ for t in NODE_TYPES if t not in cls._handlers]

    @classmethod
    def is_partial(cls) -> bool:
        """True when the pass declares a default (`generic_visit`) for the nodes it skips."""
        return cls.generic_visit is not Visitor.generic_visit
