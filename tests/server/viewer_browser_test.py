#!/usr/bin/python3
"""The web viewer in a real browser (CTest viewer_browser_test): a real strata-server with the
demo map (and a second map with a long id), Debian's headless Chromium through Selenium at
1400 x 900. Checks that the page loads without a console error and lists the maps without
cutting any text; shows a scale bar true to the view's scale; plans floor to deck from the
form and draws the trajectory with the length a gRPC client gets (the strata CLI), its labels
inside the view; names the storeys by their floors' heights, and draws a plan under the deck
dotted until the deck's storey is hidden or cut away, the hover naming the ground shown; fits
the map in the 3D view and hides the deck's storey, or cuts the deck away, there; refits the
views and the profile when the window shrinks; shows an impossible goal's error with the
nearest valid point without any console error; draws two robots' reservations at the traffic
slider's times, and marks a robot the server replanned to let another pass first; and names a
garage's decks and rugged terrain's one storey.
Exits 77 (CTest's skip) only when the browser cannot run here."""

import argparse
import json
import math
import subprocess
import sys
import time

sys.dont_write_bytecode = True  # No __pycache__ in the source tree.
from viewer_driver import Browser, Server, browser_missing  # noqa: E402

SKIP = 77
START = "2,2,0.3"
GOAL = "10,10,3.3"  # The upper deck.
OFF_GROUND_GOAL = "40,40,0.3"  # Outside the hall.
UNDER_DECK_START, UNDER_DECK_GOAL = "2,9,0.3", "15,9,0.3"  # Along the floor under the deck.
LONG_ID = "warehouse_mezzanine_north_after_the_2025_refit"  # Wraps in the map list.
DECK_RGB = (190, 196, 120)  # colors.js heightColor of the deck (3 m of the demo's 0 to 4 m).

# Counts, in the 3D view's pixels, those of the deck's colour and the box of those that are not
# background.
ORBIT_PIXELS = f"const deck = {list(DECK_RGB)};" + """
const canvas = document.getElementById('orbit-canvas');
const copy = document.createElement('canvas');
copy.width = canvas.width;
copy.height = canvas.height;
const context = copy.getContext('2d');
context.drawImage(canvas, 0, 0);
const data = context.getImageData(0, 0, copy.width, copy.height).data;
const out = { deck: 0, xMin: Infinity, xMax: -1, yMin: Infinity, yMax: -1, width: copy.width, height: copy.height };
for (let i = 0; i < data.length; i += 4) {
  const [r, g, b] = [data[i], data[i + 1], data[i + 2]];
  if (Math.abs(r - 32) + Math.abs(g - 36) + Math.abs(b - 43) < 12) continue;  // Background.
  const x = (i / 4) % copy.width;
  const y = Math.floor(i / 4 / copy.width);
  out.xMin = Math.min(out.xMin, x); out.xMax = Math.max(out.xMax, x);
  out.yMin = Math.min(out.yMin, y); out.yMax = Math.max(out.yMax, y);
  if (Math.abs(r - deck[0]) + Math.abs(g - deck[1]) + Math.abs(b - deck[2]) < 10) ++out.deck;
}
return out;
"""

# The cursor's readout with the pointer over (x, y) of the top view.
HOVER = """
const canvas = document.getElementById('top-canvas');
const [sx, sy] = window.strataViewer.views.top.toScreen(arguments[0], arguments[1]);
const box = canvas.getBoundingClientRect();
canvas.dispatchEvent(new PointerEvent('pointermove', { clientX: box.left + sx, clientY: box.top + sy, bubbles: true }));
return document.getElementById('cursor').textContent;
"""

# The map list's row heights, column widths and bottom edge: as shown, with map arguments[0]
# drawn as a map still being made (95% done, none of its figures known yet), and as shown again.
LIST_WHILE_A_MAP_IS_MADE = """
const viewer = window.strataViewer;
const table = document.getElementById('maps');
const layout = () => [[...table.rows].map((r) => r.offsetHeight),
                      [...table.tHead.rows[0].cells].map((c) => c.offsetWidth),
                      table.getBoundingClientRect().bottom];
const shown = viewer.state.maps;
const before = layout();
viewer.showMaps(shown.map((m) => (m.id !== arguments[0] ? m : {
  ...m, state: 'MAP_STATE_CREATING', progress: 0.95, valid_ground_point_count: '0', max_levels: 0,
  memory_bytes: '0', version: '' })));
const made = layout();
viewer.showMaps(shown);
return [before, made, layout()];
"""

# Each storey box's label and tooltip.
STOREYS = """
return [...document.querySelectorAll('#storeys input[data-storey]')].map(
  (box) => [box.dataset.storey, box.parentElement.textContent.trim(), box.parentElement.title]);
"""

# Every marker label's box, and the overlay's.
LABEL_BOXES = """
const view = document.getElementById('overlay').getBoundingClientRect();
return [[view.left, view.top, view.right, view.bottom],
        [...document.querySelectorAll('#overlay .marker text')].map((t) => {
          const b = t.getBoundingClientRect();
          return [t.textContent, b.left, b.top, b.right, b.bottom];
        })];
"""

# The top view's canvas size and the map's bounds on screen; the profile's width and where its
# axis ends.
TOP_FIT = """
const canvas = document.getElementById('top-canvas');
const top = window.strataViewer.views.top;
const b = window.strataViewer.state.model.bounds();
const [x0, y0] = top.toScreen(b.xMin, b.yMax);
const [x1, y1] = top.toScreen(b.xMax, b.yMin);
const profile = document.getElementById('profile');
const axis = profile.querySelector('line.axis');
return { css: [canvas.clientWidth, canvas.clientHeight], pixels: [canvas.width, canvas.height],
         ratio: window.devicePixelRatio, map: [x0, y0, x1, y1],
         profileWidth: profile.clientWidth, axisEnd: axis ? Number(axis.getAttribute('x2')) : null };
"""


def set_cut(driver, value):
    """Moves the "cut above" slider to `value` [m] ('max': no cut)."""
    driver.execute_script(
        "const s = document.getElementById('cut'); s.value = arguments[0] === 'max' ? s.max : arguments[0];"
        "s.dispatchEvent(new Event('input'));", value)


def assert_labels_inside(driver):
    view, labels = driver.execute_script(LABEL_BOXES)
    for text, left, top, right, bottom in labels:
        assert (left >= view[0] and top >= view[1] and right <= view[2] and bottom <= view[3]), \
            f"label {text!r} at {(left, top, right, bottom)} leaves the view {view}"
    return len(labels)


def assert_fitted(driver, what, timeout_s=5):
    """The top view's canvas pixels follow its CSS size, the map fills the view without leaving
    it, and the profile spans its width (within `timeout_s`: they follow at the next frame)."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            return check_fitted(driver.execute_script(TOP_FIT), what)
        except AssertionError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def check_fitted(fit, what):
    css, pixels, ratio = fit["css"], fit["pixels"], fit["ratio"]
    assert pixels == [round(css[0] * ratio), round(css[1] * ratio)], (what, fit)
    x0, y0, x1, y1 = fit["map"]
    assert x0 >= -1 and y0 >= -1 and x1 <= css[0] + 1 and y1 <= css[1] + 1, (what, fit)
    assert max((x1 - x0) / css[0], (y1 - y0) / css[1]) > 0.9, (what, fit)
    assert abs(fit["axisEnd"] - (fit["profileWidth"] - 12)) < 1, (what, fit)  # profile_view.js MARGIN.


def grpc_plan_length(cli, address):
    """stats.length_m of the same plan over gRPC, by the strata CLI."""
    out = subprocess.run(
        [cli, "--server", address, "--json", "plan", "--map", "demo", "--start", START,
         "--goal", GOAL, "--time-budget", "30"],
        check=True, capture_output=True, text=True, timeout=120).stdout
    return json.loads(out)["stats"]["length_m"]


def cli(binary, address, *command):
    """The strata CLI's output for `command` on the server (raises when it fails)."""
    done = subprocess.run([binary, "--server", address, *command], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, f"strata {' '.join(command)}: {done.stdout}{done.stderr}"
    return done.stdout


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--server", required=True, help="the strata-server binary")
    parser.add_argument("--cli", required=True, help="the strata CLI binary")
    args = parser.parse_args()
    missing = browser_missing()
    if missing:
        print(f"SKIP: {missing}")
        return SKIP

    server = Server(args.server, ["--shutdown-grace-s", "1", "--preload", "demo=scene:two_level_ramp",
                                  "--preload", f"{LONG_ID}=scene:two_level_ramp",
                                  "--preload", "garage=scene:parking_garage", "--preload", "terrain=scene:uneven_terrain"])
    browser = None
    try:
        server.wait_active("demo", 120)
        browser = Browser()
        driver = browser.driver
        driver.get(server.url)
        browser.wait("document.querySelector('#maps tr[data-map-id=\"demo\"]')", 30,
                     "the map list to show demo")
        # Every map assessed, and the list showing them so, before anything is clicked (the
        # list is rebuilt every 2 s while a map is being made; later steps open each map).
        for map_id in (LONG_ID, "garage", "terrain"):
            server.wait_active(map_id, 240)
        browser.wait("[...document.querySelectorAll('#maps td.state')]"
                     ".filter((c) => c.classList.contains('state-MAP_STATE_ACTIVE')).length === 4", 30,
                     "the map list to show every map active")
        # A map turning active leaves the list's rows and columns as they were, so nothing below
        # it moves: the list drawn with the garage still being made (95% done, no figures yet)
        # against the list as it is.
        layouts = driver.execute_script(LIST_WHILE_A_MAP_IS_MADE, "garage")
        assert layouts[0] == layouts[1] == layouts[2], layouts
        garage_state = driver.find_element("css selector", '#maps tr[data-map-id="garage"] td.state')
        assert garage_state.text == "active", garage_state.text
        row = driver.find_element("css selector", '#maps tr[data-map-id="demo"]')
        assert "active" in row.text, row.text
        # Before a map is picked the view says what to do, and not after.
        landing = driver.find_element("id", "landing")
        assert landing.is_displayed() and "Pick a map" in landing.text, landing.text
        row.click()
        browser.wait("document.body.dataset.mapDrawn === 'demo'", 60, "the demo map drawn")
        assert not landing.is_displayed()
        # The storeys as a person reads them: the floor and the deck (scenes/src/rooms.cpp: at 0
        # and 3 m), named by their height, the bands split half way; no box by the per-column
        # level (which counts a column's grounds from the bottom, the ramp's too).
        storeys = driver.execute_script(STOREYS)
        assert [(s, name) for s, name, _ in storeys] == [("0", "ground 0.0 m"), ("1", "deck 3.0 m")], storeys
        assert storeys[0][2].endswith(" … 1.5 m: the floor at 0.0 m with the ramps and obstacle tops at these heights"), storeys
        assert storeys[1][2].startswith("1.5 … "), storeys
        assert not driver.find_elements("css selector", "[data-level]")
        # The scale bar: a round length, as long on screen as the view's scale makes it.
        bar = driver.find_element("id", "scale-bar")
        scale = driver.execute_script("return window.strataViewer.views.top.scale;")
        bar_m, bar_px = float(bar.get_attribute("data-length-m")), float(bar.get_attribute("data-width-px"))
        assert 30 < bar_px <= 120 and abs(bar_px - bar_m * scale) < 0.5, (bar_m, bar_px, scale)
        assert bar.text == f"{bar_m:g} m", bar.text

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
        assert assert_labels_inside(driver) == 2
        assert driver.find_element("id", "search-path").get_attribute("points")
        assert driver.find_elements("css selector", "#profile polyline.reference")
        # The side's text all shows (ids wrap, nothing scrolls sideways), now that the plan's
        # figures make it scroll.
        cut_cells = driver.execute_script(
            "return [...document.querySelectorAll('#maps th, #maps td')]"
            ".filter((c) => c.scrollWidth > c.clientWidth).map((c) => c.textContent);")
        assert not cut_cells, f"map list cells cut: {cut_cells}"
        side = driver.execute_script("const s = document.getElementById('side'); return [s.scrollWidth, s.clientWidth];")
        assert side[0] <= side[1], f"the side overflows sideways: {side}"

        # Along the floor under the deck: drawn dotted while the deck's storey is shown, solid
        # once it is hidden; the hover names the deck there, then the floor.
        browser.plan(UNDER_DECK_START, UNDER_DECK_GOAL, 30)
        assert not driver.find_elements("id", "plan-error"), driver.find_element("id", "plan-error").text
        count = "[...document.querySelectorAll('#trajectory line')].filter((l) => l.classList.contains('covered')).length"
        total = len(driver.find_elements("css selector", "#trajectory line"))
        covered = driver.execute_script(f"return {count};")
        assert covered > 0.8 * total, f"{covered} of {total} segments under the deck drawn dotted"
        deck_storey = driver.find_element("css selector", '#storeys input[data-storey="1"]')
        hover = driver.execute_script(HOVER, 8, 9)
        assert hover.endswith('ground 3.00 m (storey "deck 3.0 m", 2nd ground of its column)'), hover
        deck_storey.click()
        covered = driver.execute_script(f"return {count};")
        assert covered == 0, f"{covered} segments still dotted with the deck hidden"
        hover = driver.execute_script(HOVER, 8, 9)
        assert hover.endswith('ground 0.00 m (storey "ground 0.0 m", 1st ground of its column)'), hover
        deck_storey.click()
        # Cut away above 1.5 m: the deck no longer covers the plan; and back.
        set_cut(driver, 1.5)
        browser.wait(f"{count} === 0", 5, "the plan drawn solid with the deck cut away")
        assert driver.find_element("id", "cut-value").text == "1.5 m"
        set_cut(driver, "max")
        browser.wait(f"{count} > 0.8 * {total}", 5, "the plan drawn dotted again without a cut")

        # 3D: the map fitted in the view (inside it, filling most of it), the deck cut away.
        driver.find_element("css selector", "input[name=view][value=orbit]").click()
        pixels = browser.wait(f"(() => {{ const p = (() => {{ {ORBIT_PIXELS} }})(); return p.deck > 2000 && p; }})()",
                              10, "the 3D view drawn")
        w, h = pixels["width"], pixels["height"]
        assert pixels["xMin"] > 0 and pixels["yMin"] > 0 and pixels["xMax"] < w - 1 and pixels["yMax"] < h - 1, \
            f"the map leaves the 3D view: {pixels}"
        assert max((pixels["xMax"] - pixels["xMin"]) / w, (pixels["yMax"] - pixels["yMin"]) / h) > 0.75, \
            f"the map does not fill the 3D view: {pixels}"
        set_cut(driver, 1.5)
        browser.wait(f"(() => {{ {ORBIT_PIXELS} }})().deck < {pixels['deck'] // 50}", 10, "the deck cut away in 3D")
        set_cut(driver, "max")
        # Unticking the deck's storey hides the deck there too, the floor's keeps it.
        orbit_deck = f"(() => {{ {ORBIT_PIXELS} }})().deck"
        for storey, hidden, shown in (("1", f"{orbit_deck} < {pixels['deck'] // 50}", "the deck's storey hidden in 3D"),
                                      ("0", f"{orbit_deck} > {pixels['deck'] * 0.9}", "the deck kept with the floor's storey hidden")):
            box = driver.find_element("css selector", f'#storeys input[data-storey="{storey}"]')
            box.click()
            browser.wait(hidden, 10, shown)
            box.click()
            browser.wait(f"{orbit_deck} > {pixels['deck'] * 0.9}", 10, "the deck drawn again in 3D")
        driver.find_element("css selector", "input[name=view][value=top]").click()

        # A smaller window: the top view and the profile follow it, the map fitted again.
        assert_fitted(driver, "at 1400 x 900")
        width = driver.execute_script("return document.getElementById('top-canvas').clientWidth;")
        driver.set_window_size(1000, 700)
        browser.wait(f"document.getElementById('top-canvas').clientWidth < {width - 300}", 10, "a smaller view")
        assert_fitted(driver, "at 1000 x 700")
        driver.set_window_size(1400, 900)
        browser.wait(f"document.getElementById('top-canvas').clientWidth === {width}", 10, "the view as before")
        assert_fitted(driver, "at 1400 x 900 again")

        errors = browser.console_errors()
        assert not errors, f"console errors: {errors}"

        # An impossible goal: its error in plain words, with the nearest valid point (at the
        # map's edge: its label turns inwards), and nothing in the console.
        browser.plan(START, OFF_GROUND_GOAL, 30)
        error = driver.find_element("id", "plan-error")
        assert error.get_attribute("data-reason") == "GOAL_OFF_GROUND", error.text
        assert "nearest point it can reach" in error.text, error.text
        assert driver.find_elements("id", "nearest-marker")
        assert assert_labels_inside(driver) >= 2
        errors = browser.console_errors()
        assert not errors, f"console errors after a refused plan: {errors}"

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

        # A robot replanned to let another pass first (server_fleet_test's scenario, by the CLI:
        # "up" climbs the ramp following replans; "down", on the deck, must come down at once,
        # 2 m clear of it, and may replan one robot): "up"'s disc and route are marked, with the
        # robot it let pass, "down"'s are not; still nothing drawn in conflict.
        for robot in ("r1", "r2"):
            cli(args.cli, server.address, "reservations", "release", "--map", "demo", "--robot-id", robot)
        cli(args.cli, server.address, "plan", "--map", "demo", "--start", "1,5.25,0.3",
            "--goal", "7,9.25,3.3", "--robot-id", "up", "--reserve", "--follows-replans",
            "--time-budget", "30")
        down = json.loads(cli(args.cli, server.address, "--json", "plan", "--map", "demo",
                              "--start", "10,9.25,3.3", "--goal", "10,9.5,0.3", "--robot-id", "down",
                              "--reserve", "--max-wait", "0", "--separation", "2.0",
                              "--replan-robots", "1", "--time-budget", "30"))
        assert [r["robot_id"] for r in down.get("replanned", [])] == ["up"], \
            f"the scenario replanned {down.get('replanned')}, not up: it tests nothing"
        driver.find_element("id", "refresh-traffic").click()
        browser.wait("document.querySelector('#traffic circle[data-robot-id=\"down\"]')"
                     " && document.querySelectorAll('#traffic circle.robot').length === 2", 20,
                     "the robots up and down drawn")
        for end in ("min", "max"):
            driver.execute_script(slide.format(end))
            up = driver.find_element("css selector", '#traffic circle[data-robot-id="up"]')
            assert "replanned" in up.get_attribute("class").split(), (end, up.get_attribute("class"))
            assert up.get_attribute("data-replanned-for") == "down", (end, up.get_attribute("data-replanned-for"))
            title = up.find_element("css selector", "title").get_attribute("textContent")
            assert title.endswith("replanned to let down pass first"), (end, title)
            down_disc = driver.find_element("css selector", '#traffic circle[data-robot-id="down"]')
            assert "replanned" not in down_disc.get_attribute("class").split(), (end, down_disc.get_attribute("class"))
            assert down_disc.get_attribute("data-replanned-for") is None, end
            routes = driver.find_elements("css selector", "#traffic polyline.route.replanned")
            assert [r.get_attribute("data-robot-id") for r in routes] == ["up"], end
            conflicts = driver.find_element("id", "traffic").get_attribute("data-conflicts")
            assert conflicts == "0", f"{conflicts} robots drawn in conflict at the slider's {end}"

        # A pair is judged by the larger separation its reservations ask (Reservation.
        # separation_m): two robots parked 0.75 m apart, radii 0.3 m, conflict when either asks
        # 0.2 m and not when both ask 0.1 m, whatever the server's default.
        pair_conflicts = driver.execute_async_script("""
            const done = arguments[arguments.length - 1];
            const parked = (id, x, separation) => ({
              robot_id: id, separation_m: separation,
              start_time: '2026-12-05T00:00:00Z', expiry_time: '2026-12-05T00:01:00Z',
              body: {radius_m: 0.3, reference_height_m: 0.3, height_m: 1.0},
              trajectory: {duration_s: 1, pieces: [{duration_s: 1, axes: [
                {coefficients: [x]}, {coefficients: [0]}, {coefficients: [0.3]}]}]},
            });
            import('/js/traffic.js').then(({Traffic}) => {
              const count = (a, b) => {
                const traffic = new Traffic({separation_m: 0.1, reservations: [a, b]});
                return traffic.conflictsAt(traffic.positionsAt(Date.parse('2026-12-05T00:00:30Z') / 1000)).length;
              };
              done([count(parked('a', 0, 0.1), parked('b', 0.75, 0.2)),
                    count(parked('a', 0, 0.2), parked('b', 0.75, 0.1)),
                    count(parked('a', 0, 0.1), parked('b', 0.75, 0.1))]);
            }, (e) => done(String(e)));""")
        assert pair_conflicts == [1, 1, 0], pair_conflicts

        # Other maps' storeys: parking_garage's four decks 2.8 m apart (scenes/src/garage.cpp),
        # uneven_terrain's hills one storey.
        for map_id, names in (("garage", ["ground 0.0 m", "deck 2.8 m", "deck 5.6 m", "deck 8.4 m"]),
                              ("terrain", None)):
            # As a click on its row does (the list, rebuilt as it reloads, would race a click).
            driver.execute_script("window.strataViewer.selectMap(arguments[0]);", map_id)
            browser.wait(f"document.body.dataset.mapDrawn === '{map_id}'", 60, f"{map_id} drawn")
            storeys = [name for _, name, _ in driver.execute_script(STOREYS)]
            if names:
                assert storeys == names, (map_id, storeys)
            else:
                assert len(storeys) == 1 and storeys[0].startswith("ground"), (map_id, storeys)

        errors = browser.console_errors()
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
