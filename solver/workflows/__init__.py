"""Shape-variable workflows: basis shapes, DOE plans, safe bounds, sensitivities.

* :mod:`.shapes` -- SHAPES documents and the MOVE of a parameter vector;
* :mod:`.plan` -- PLAN tables (CSV or rows in memory);
* :mod:`.doe` -- every plan row morphed through one precompute, rows stacked per back-substitution;
* :mod:`.bounds` -- per shape, the largest values that invert no element;
* :mod:`.sensitivities` -- ``dX / d theta_k`` per node;
* :mod:`.commands` -- the ``doe``, ``bounds`` and ``sensitivities`` commands.
"""

from .bounds import BoundsResult, ShapeBounds, Side, shape_bounds
from .doe import DoeResult, Variant, deck_writer, run_doe, write_summary
from .plan import Plan, parse_plan, plan_values, read_plan
from .sensitivities import Sensitivities, shape_sensitivities, write_sensitivities
from .shapes import Shapes, combine, parse_shapes, variant_move

__all__ = ["Shapes", "parse_shapes", "combine", "variant_move", "Plan", "parse_plan", "read_plan", "plan_values",
           "DoeResult", "Variant", "run_doe", "deck_writer", "write_summary", "BoundsResult", "ShapeBounds", "Side",
           "shape_bounds", "Sensitivities", "shape_sensitivities", "write_sensitivities"]
