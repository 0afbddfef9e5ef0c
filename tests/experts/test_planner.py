"""The goal planner's ordering rules, on real BDDL goals, without a simulator."""

from __future__ import annotations

from libero_data.bddl import parse
from libero_data.experts.planner import plan
from libero_data.tasks import get_task


def steps(ref: str, **kw) -> list[str]:
    return [str(s) for s in plan(get_task(ref).problem, **kw)]


def test_pick_and_place() -> None:
    assert steps("libero_object/0") == [
        "pick(alphabet_soup_1, basket_1_contain_region)",
        "place_in(alphabet_soup_1, basket_1_contain_region)",
    ]
    assert steps("libero_spatial/3") == [
        "pick(akita_black_bowl_1, plate_1)",
        "place_on(akita_black_bowl_1, plate_1)",
    ]


def test_closed_drawer_is_opened_first_and_closed_after() -> None:
    # libero_10/3: put the black bowl in the bottom drawer of the cabinet and close it
    drawer = "white_cabinet_1_bottom_region"
    kind = {drawer: "slide"}
    out = steps("libero_10/3", joint_kind=kind.get, is_open=lambda r: False)
    assert out == [
        f"open_drawer({drawer})",
        f"pick(akita_black_bowl_1, {drawer})",
        f"place_in(akita_black_bowl_1, {drawer})",
        f"close_drawer({drawer})",
    ]
    # An open drawer is not opened again.
    assert (
        steps("libero_10/3", joint_kind=kind.get, is_open=lambda r: True)[0]
        == f"pick(akita_black_bowl_1, {drawer})"
    )


def test_stove_is_turned_on_before_the_pot_goes_on_it() -> None:
    out = steps("libero_10/2")  # turn on the stove and put the moka pot on it
    assert out == [
        "turn_on(flat_stove_1)",
        "pick(moka_pot_1, flat_stove_1_cook_region)",
        "place_on(moka_pot_1, flat_stove_1_cook_region)",
    ]


def test_a_moved_target_moves_first() -> None:
    # libero_90/63: stack the left bowl on the right bowl and place them in the tray
    out = steps("libero_90/63")
    assert out.index("place_in(akita_black_bowl_2, wooden_tray_1_contain_region)") < out.index(
        "place_on(akita_black_bowl_1, akita_black_bowl_2)"
    )


def test_doors_and_flat_objects() -> None:
    assert steps("libero_10/9", joint_kind={"microwave_1": "hinge"}.get)[-1] == "close_door(microwave_1)"
    assert steps("libero_90/35", joint_kind={"microwave_1": "hinge"}.get) == ["open_door(microwave_1)"]
    assert steps("libero_goal/5", graspable=lambda o: o != "plate_1") == [
        "push(plate_1, main_table_stove_front_region)"
    ]


def test_written_order_of_switches_is_kept() -> None:
    text = get_task("libero_90/23").bddl_path.read_text()  # close the bottom drawer and open the top one
    problem = parse(text)
    kinds = dict.fromkeys(["white_cabinet_1_bottom_region", "white_cabinet_1_top_region"], "slide")
    out = [str(s) for s in plan(problem, joint_kind=kinds.get)]
    assert out == ["close_drawer(white_cabinet_1_bottom_region)", "open_drawer(white_cabinet_1_top_region)"]


def test_a_drawer_the_goal_opens_is_opened_once() -> None:
    # libero_90/8: open the top drawer of the cabinet and put the bowl in it
    drawer = "wooden_cabinet_1_top_region"
    out = steps("libero_90/8", joint_kind={drawer: "slide"}.get, is_open=lambda r: False)
    assert out == [
        f"open_drawer({drawer})",
        f"pick(akita_black_bowl_1, {drawer})",
        f"place_in(akita_black_bowl_1, {drawer})",
    ]


def test_what_an_opening_drawer_would_cover_is_pushed_aside_first() -> None:
    drawer = "wooden_cabinet_1_top_region"
    out = steps(
        "libero_90/8",
        joint_kind={drawer: "slide"}.get,
        is_open=lambda r: False,
        covered=lambda d, o: (d, o) == (drawer, "akita_black_bowl_1"),
    )
    assert out == [
        f"push_aside(akita_black_bowl_1, {drawer})",
        f"open_drawer({drawer})",
        f"pick(akita_black_bowl_1, {drawer})",
        f"place_in(akita_black_bowl_1, {drawer})",
    ]
