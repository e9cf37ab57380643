"""Level parameters as written in configs/levels/*.yaml, resolved for one difficulty.

A parameter is one of:
- a number: the same at every difficulty;
- a list of 11 numbers: the value at difficulty 0..10;
- a string: an expression in ``d`` (the difficulty) using + - * / // % **, parentheses and
  round, floor, ceil, min, max, abs, clamp(x, low, high). Example: ``"round(0.4 * d + 1)"``.
"""

from __future__ import annotations

import ast
import math
import operator
from typing import Any, Callable, Mapping

DIFFICULTIES = range(0, 11)

_BINARY: dict[type[ast.operator], Callable[[Any, Any], Any]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.FloorDiv: operator.floordiv,
    ast.Mod: operator.mod,
    ast.Pow: lambda base, exponent: _power(base, exponent),
}
MAX_EXPRESSION = 200  # characters: a parameter's expression is a line, never a program
_FUNCTIONS: dict[str, Callable[..., Any]] = {
    "round": round,
    "floor": math.floor,
    "ceil": math.ceil,
    "min": min,
    "max": max,
    "abs": abs,
    "clamp": lambda x, low, high: max(low, min(high, x)),
}


class LevelParamError(ValueError):
    """A level parameter that cannot be resolved."""


def _power(base, exponent):
    """``base ** exponent``: exact for small integers, else in floats, so that ``9**9**9`` overflows
    (an error) at once instead of computing a number of 370 million digits."""
    if isinstance(base, int) and isinstance(exponent, int) and abs(base) <= 2**32 and 0 <= exponent <= 64:
        return base**exponent
    return float(base) ** float(exponent)


def _evaluate(node: ast.AST, d: int) -> float:
    if isinstance(node, ast.Expression):
        return _evaluate(node.body, d)
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return node.value
    if isinstance(node, ast.Name) and node.id == "d":
        return d
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return _BINARY[type(node.op)](_evaluate(node.left, d), _evaluate(node.right, d))
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        value = _evaluate(node.operand, d)
        return -value if isinstance(node.op, ast.USub) else value
    if (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name)
        and node.func.id in _FUNCTIONS
        and not node.keywords
    ):
        return _FUNCTIONS[node.func.id](*(_evaluate(arg, d) for arg in node.args))
    raise LevelParamError(f"'{ast.unparse(node)}' is not allowed")


def resolve_value(value: Any, d: int, where: str) -> float:
    """One parameter's value at difficulty d; ``where`` names it in error messages."""
    allowed = "a number, a list of 11 numbers (difficulty 0..10) or an expression in d"
    if isinstance(value, bool):
        raise LevelParamError(f"{where}: got {value!r}; allowed: {allowed}")
    if isinstance(value, (int, float)):
        return value
    if isinstance(value, list):
        if len(value) != len(DIFFICULTIES) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
        ):
            raise LevelParamError(f"{where}: got {value!r}; allowed: {allowed}")
        return value[d]
    if isinstance(value, str):
        if len(value) > MAX_EXPRESSION:
            raise LevelParamError(
                f"{where}: an expression of {len(value):,} characters; allowed: {allowed}, of at most {MAX_EXPRESSION}"
            )
        try:
            result = _evaluate(ast.parse(value, mode="eval"), d)
        except OverflowError:
            raise LevelParamError(
                f"{where}: expression {value!r} is too large to compute; allowed: {allowed}"
            ) from None
        except (SyntaxError, LevelParamError, TypeError, ZeroDivisionError, ValueError) as error:
            raise LevelParamError(f"{where}: expression {value!r} fails: {error}; allowed: {allowed}") from None
        except (RecursionError, MemoryError):
            raise LevelParamError(f"{where}: expression {value!r} nests too deeply; allowed: {allowed}") from None
        if isinstance(result, complex):  # (-8) ** 0.5
            raise LevelParamError(
                f"{where}: expression {value!r} gives {result!r}, not a real number; allowed: {allowed}"
            )
        return result
    raise LevelParamError(f"{where}: got {value!r}; allowed: {allowed}")


def resolve(params: Mapping[str, Any], d: int, expected: tuple[str, ...], source: str) -> dict[str, float]:
    """All of a level's parameters at difficulty d, checked against the generator's names."""
    unknown = sorted(set(params) - set(expected))
    if unknown:
        raise LevelParamError(f"{source}: parameter '{unknown[0]}' does not exist; allowed: {', '.join(expected)}")
    missing = [name for name in expected if name not in params]
    if missing:
        raise LevelParamError(f"{source}: parameter '{missing[0]}' is missing; required: {', '.join(expected)}")
    return {name: resolve_value(params[name], d, f"{source}: parameter '{name}'") for name in expected}
