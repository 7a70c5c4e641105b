"""docs/contract.md §4 collisions, broad phase: :class:`vcran.core.collisions.Grid` returns every robot whose box meets a
robot's new box, in index order (a superset is allowed: vcran.sim.contacts tests boxes before anything else).

Cells are 20 m; the expectations are worked out by hand from the cells each box's corners fall in.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from vcran.core.collisions import Grid, apart


def test_s4_a_robot_alone_in_its_cells_has_no_neighbours():
    grid = Grid(20.0)
    assert grid.file(0, (1.0, 1.0, 5.0, 5.0)) == []  # cell (0, 0)
    assert grid.file(1, (41.0, 1.0, 45.0, 5.0)) == []  # cell (2, 0)
    assert grid.file(2, (15.0, 15.0, 25.0, 18.0)) == [0]  # cells (0, 0) and (1, 0)
    assert grid.file(0, (1.0, 1.0, 5.0, 5.0)) == [2]


def test_s4_negative_cells_are_cells_of_their_own():
    # floor(-5 / 20) = -1: four robots around the origin, in four different cells
    grid = Grid(20.0)
    for index, (x, y) in enumerate([(5.0, 5.0), (-5.0, 5.0), (-5.0, -5.0), (5.0, -5.0)]):
        assert grid.file(index, (x - 1.0, y - 1.0, x + 1.0, y + 1.0)) == []
    # a box over the origin touches all four cells: all four robots, in index order, each once
    assert grid.file(4, (-1.0, -1.0, 1.0, 1.0)) == [0, 1, 2, 3]


def test_s4_a_neighbour_in_the_far_cell_of_a_long_box_is_found():
    grid = Grid(20.0)
    assert grid.file(0, (93.0, 1.0, 95.0, 3.0)) == []  # cell (4, 0)
    assert grid.file(1, (-10.0, 1.0, 90.0, 3.0)) == [0]  # cells (-1, 0) .. (4, 0): only the last is shared
    assert grid.file(2, (-10.0, -3.0, -8.0, -1.0)) == []  # cell (-1, -1): the row below the leg's


def test_s4_a_robot_resting_inside_its_filing_keeps_it_and_moving_away_leaves_it():
    grid = Grid(20.0)
    assert grid.file(0, (1.0, 1.0, 25.0, 5.0)) == []  # a leg's box: cells (0, 0) and (1, 0)
    assert grid.file(1, (30.0, 1.0, 35.0, 5.0)) == [0]  # cell (1, 0)
    # at rest in (0, 0), inside its filing: the filing (and so neighbour 1) is kept
    assert grid.file(0, (1.0, 1.0, 5.0, 5.0)) == [1]
    assert grid.file(0, (-15.0, 1.0, -5.0, 5.0)) == []  # cell (-1, 0): it leaves (0, 0) and (1, 0)
    assert grid.file(1, (30.0, 1.0, 35.0, 5.0)) == []
    assert len(grid.cells) == 2 and all(grid.cells.values())  # (-1, 0) and (1, 0); (0, 0) emptied and dropped


coord = st.integers(-60, 60).map(float)


@st.composite
def boxes(draw):
    x, y = draw(coord), draw(coord)
    return x, y, x + draw(st.integers(0, 50)), y + draw(st.integers(0, 50))


@settings(max_examples=200)
@given(st.lists(st.tuples(st.integers(0, 5), boxes()), min_size=1, max_size=40))
def test_s4_grid_returns_every_robot_whose_box_meets_the_new_one(moves):
    # brute force over the latest box of every robot: the alone fast path and the kept filing of a robot at
    # rest may only add robots, never drop one whose box meets (touching edges and corners included)
    grid, latest = Grid(20.0), {}
    for index, box in moves:
        near = grid.file(index, box)
        latest[index] = box
        must = {j for j, other in latest.items() if j != index and not apart(box, other)}
        assert must <= set(near) and index not in near
        assert near == sorted(set(near))
        assert set(near) <= set(latest)
