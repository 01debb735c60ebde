#!/usr/bin/python3
"""The web viewer in a real browser (CTest viewer_browser_test): a real strata-server with the
demo map, Debian's headless Chromium through Selenium. Checks that the page loads without a
console error, lists the demo map, plans floor to deck from the form and draws the trajectory
with the length a gRPC client gets (the strata CLI), draws a plan under the deck dotted until
the deck's level is hidden, and shows an impossible goal's error with the nearest valid
point, and draws two robots' reservations at the traffic slider's times. Exits 77 (CTest's
skip) only when the browser cannot run here."""

import argparse
import json
import math
import subprocess
import sys

sys.dont_write_bytecode = True  # No __pycache__ in the source tree.
from viewer_driver import Browser, Server, browser_missing  # noqa: E402

SKIP = 77
START = "2,2,0.3"
GOAL = "10,10,3.3"  # The upper deck.
OFF_GROUND_GOAL = "40,40,0.3"  # Outside the hall.
UNDER_DECK_START, UNDER_DECK_GOAL = "2,9,0.3", "15,9,0.3"  # Along the floor under the deck.


def grpc_plan_length(cli, address):
    """stats.length_m of the same plan over gRPC, by the strata CLI."""
    out = subprocess.run(
        [cli, "--server", address, "--json", "plan", "--map", "demo", "--start", START,
         "--goal", GOAL, "--time-budget", "30"],
        check=True, capture_output=True, text=True, timeout=120).stdout
    return json.loads(out)["stats"]["length_m"]


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--server", required=True, help="the strata-server binary")
    parser.add_argument("--cli", required=True, help="the strata CLI binary")
    args = parser.parse_args()
    missing = browser_missing()
    if missing:
        print(f"SKIP: {missing}")
        return SKIP

    server = Server(args.server, ["--shutdown-grace-s", "1"])
    browser = None
    try:
        server.wait_active("demo", 120)
        browser = Browser()
        driver = browser.driver
        driver.get(server.url)
        browser.wait("document.querySelector('#maps tr[data-map-id=\"demo\"]')", 30,
                     "the map list to show demo")
        row = driver.find_element("css selector", '#maps tr[data-map-id="demo"]')
        assert "active" in row.text, row.text
        # Before a map is picked the view says what to do, and not after.
        landing = driver.find_element("id", "landing")
        assert landing.is_displayed() and "Pick a map" in landing.text, landing.text
        row.click()
        browser.wait("document.body.dataset.mapDrawn === 'demo'", 60, "the demo map drawn")
        assert not landing.is_displayed()
        levels = driver.find_elements("css selector", "#levels input[data-level]")
        assert len(levels) == 2, f"the demo has a floor and a deck, the page shows {len(levels)} levels"

        # A plan from the form: drawn, and as long as the gRPC answer.
        browser.plan(START, GOAL, 30)
        error = driver.find_elements("id", "plan-error")
        assert not error, "the plan failed: " + error[0].text
        page_length = float(driver.find_element("id", "plan-figures").get_attribute("data-length-m"))
        grpc_length = grpc_plan_length(args.cli, server.address)
        assert math.isclose(page_length, grpc_length, rel_tol=1e-9), (page_length, grpc_length)
        trajectory = driver.find_element("id", "trajectory")
        segments = trajectory.find_elements("css selector", "line")
        drawn_length = float(trajectory.get_attribute("data-length-m"))
        assert len(segments) > 20, f"only {len(segments)} trajectory segments drawn"
        # The drawn polyline (samples every 5 cm) is the trajectory's arc length within 1 %.
        assert abs(drawn_length - grpc_length) < 0.01 * grpc_length, (drawn_length, grpc_length)
        # It is drawn where the trajectory is: its first point at the start, on screen.
        first = segments[0]
        assert abs(float(first.get_attribute("x1")) - 2) < 0.3, first.get_attribute("x1")
        box = trajectory.rect
        assert box["width"] > 50 and box["height"] > 50, box
        goal_label = driver.find_element("id", "goal-marker").text
        # Named by its ground's height, as a person reads a storey (the deck is at 3 m).
        assert goal_label == "goal · ground 3.0 m", goal_label
        assert driver.find_element("id", "search-path").get_attribute("points")
        assert driver.find_elements("css selector", "#profile polyline.reference")

        # Along the floor under the deck: drawn dotted while the deck (level 1) is shown, solid
        # once it is hidden.
        browser.plan(UNDER_DECK_START, UNDER_DECK_GOAL, 30)
        assert not driver.find_elements("id", "plan-error"), driver.find_element("id", "plan-error").text
        count = "[...document.querySelectorAll('#trajectory line')].filter((l) => l.classList.contains('covered')).length"
        total = len(driver.find_elements("css selector", "#trajectory line"))
        covered = driver.execute_script(f"return {count};")
        assert covered > 0.8 * total, f"{covered} of {total} segments under the deck drawn dotted"
        driver.find_element("css selector", '#levels input[data-level="1"]').click()
        covered = driver.execute_script(f"return {count};")
        assert covered == 0, f"{covered} segments still dotted with the deck hidden"
        driver.find_element("css selector", '#levels input[data-level="1"]').click()

        errors = browser.console_errors()
        assert not errors, f"console errors: {errors}"

        # An impossible goal: its error in plain words, with the nearest valid point.
        browser.plan(START, OFF_GROUND_GOAL, 30)
        error = driver.find_element("id", "plan-error")
        assert error.get_attribute("data-reason") == "GOAL_OFF_GROUND", error.text
        assert "nearest point it can reach" in error.text, error.text
        assert driver.find_elements("id", "nearest-marker")

        # Both plans are among the recent plans.
        browser.wait("document.querySelectorAll('#recent li').length >= 2", 20, "the recent plans")
        recent = driver.find_element("id", "recent").text
        assert "GOAL_OFF_GROUND" in recent and "via http" in recent, recent

        # Two robots' reservations across the floor (the second crosses the first's way): the
        # traffic section draws each as a disc on its route at the slider's time, at their
        # starts at the slider's start and at their goals at its end, never in conflict.
        for robot, start, goal in (("r1", "3,5,0.3", "13,10,0.3"), ("r2", "3,10,0.3", "13,5,0.3")):
            subprocess.run(
                [args.cli, "--server", server.address, "plan", "--map", "demo", "--start", start,
                 "--goal", goal, "--robot-id", robot, "--reserve", "--time-budget", "30"],
                check=True, capture_output=True, text=True, timeout=120)
        driver.find_element("id", "refresh-traffic").click()
        browser.wait("document.querySelectorAll('#traffic circle.robot').length === 2", 20,
                     "the two reserved robots drawn")
        assert len(driver.find_elements("css selector", "#traffic polyline.route")) == 2
        slide = ("const s = document.getElementById('traffic-time'); s.value = s.{};"
                 "s.dispatchEvent(new Event('input'));")
        for end, expected in (("min", {"r1": (3, 5)}), ("max", {"r1": (13, 10), "r2": (13, 5)})):
            driver.execute_script(slide.format(end))
            for robot, (x, y) in expected.items():
                disc = driver.find_element("css selector", f'#traffic circle[data-robot-id="{robot}"]')
                cx, cy = float(disc.get_attribute("cx")), float(disc.get_attribute("cy"))
                assert math.hypot(cx - x, cy - y) < 0.5, (end, robot, cx, cy)
            conflicts = driver.find_element("id", "traffic").get_attribute("data-conflicts")
            assert conflicts == "0", f"{conflicts} robots drawn in conflict at the slider's {end}"

        # The only console entry since: Chromium reporting the refused plan's HTTP 400.
        errors = [e for e in browser.console_errors()
                  if not (e["source"] == "network" and "PlannerService/Plan" in e["message"]
                          and "status of 400" in e["message"])]
        assert not errors, f"console errors: {errors}"
        print(f"ok: plan {page_length:.3f} m on the page and over gRPC; "
              f"{len(segments)} segments drawn ({drawn_length:.3f} m); off-ground goal shown")
        return 0
    except Exception:
        sys.stderr.write("--- strata-server log ---\n" + "".join(server.log))
        raise
    finally:
        if browser:
            browser.quit()
        server.stop()


if __name__ == "__main__":
    sys.exit(main())
