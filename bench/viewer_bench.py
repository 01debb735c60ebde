#!/usr/bin/python3
"""The web viewer's load time and frame rate on the shared maps (spiral, scene20.2) and a site
scene, and the README's screenshots (the spiral and the site, each with a plan), in Debian's
headless Chromium.

  /usr/bin/python3 bench/viewer_bench.py --server build/server/strata-server \\
      [--maps ../shared/maps] [--runs 5] [--screenshots docs/img]

Starts strata-server with the spiral and scene20.2 at 0.2 m, the outdoor_site scene and the
demo preloaded and the viewer on; for each map and each of --runs fresh page loads of
`#map=ID` it reads the navigation timing and the time the map's first frame was drawn (the
page's `strata-map-drawn:ID` mark), then pans the top view and orbits the 3D view for 3 s
each, counting animation frames. Prints the medians. With --screenshots, plans on both maps from the
page and saves viewer_spiral.png, viewer_spiral_3d.png and viewer_site.png there. Run it under
the shared lock (flock /tmp/strata-heavy.lock ...): it measures."""

import argparse
import os
import statistics
import sys

sys.dont_write_bytecode = True  # No __pycache__ in the source tree.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "server"))
from viewer_driver import Browser, Server, browser_missing  # noqa: E402

SPIRAL_START = "-30,-2,1.5"
SPIRAL_GOAL = "-30,-28,21.5"  # The top deck, as in the README's strata-offline example.


def open_map(browser, url, map_id):
    """A fresh page load of `url#map=ID`; the navigation's timings and the map's first frame [ms]."""
    driver = browser.driver
    driver.get("about:blank")
    driver.get(f"{url}#map={map_id}")
    browser.wait(f"performance.getEntriesByName('strata-map-drawn:{map_id}').length", 120,
                 f"{map_id} drawn")
    return driver.execute_script(f"""
        const nav = performance.getEntriesByType('navigation')[0];
        return {{
          response_ms: nav.responseEnd,
          load_ms: nav.loadEventEnd,
          drawn_ms: performance.getEntriesByName('strata-map-drawn:{map_id}')[0].startTime,
          surfaces: window.strataViewer.state.model.surfaceCount,
          stride: window.strataViewer.state.model.geometry.stride,
        }};""")


def frames_per_second(browser, view, seconds=3):
    driver = browser.driver
    driver.execute_script(f"document.querySelector('input[name=view][value={view}]').click();")
    fps = driver.execute_async_script(
        f"const done = arguments[arguments.length - 1];"
        f"window.strataViewer.measureFrames('{view}', {seconds}).then(done);")
    driver.execute_script("document.querySelector('input[name=view][value=top]').click();")
    return fps


def plan(browser, start, goal, robot="differential"):
    browser.plan(start, goal, 10, robot=robot)
    error = browser.driver.find_elements("id", "plan-error")
    if error:
        raise RuntimeError("plan failed: " + error[0].text)


def site_query(server):
    """Two far-apart points on the largest connected ground of the site, for the biped."""
    g = server.call("strata.v1.MapService/GetMapGeometry",
                    {"map_id": "site", "profile_name": "biped", "max_bytes": 2000000})
    sizes = {}
    for c in g["ground_component"]:
        if c >= 0:
            sizes[c] = sizes.get(c, 0) + 1
    largest = max(sizes, key=sizes.get)
    points = []
    for cell, z, c in zip(g["ground_cell"], g["ground_z_m"], g["ground_component"]):
        if c == largest:
            x = g["origin_m"]["x"] + (cell % g["nx"] + 0.5) * g["cell_size_m"]
            y = g["origin_m"]["y"] + (cell // g["nx"] + 0.5) * g["cell_size_m"]
            points.append((x, y, z + 0.3))
    # Nearest to a fifth of the way in from two opposite corners (away from the site's rim).
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]

    def nearest(fx, fy):
        x = min(xs) + fx * (max(xs) - min(xs))
        y = min(ys) + fy * (max(ys) - min(ys))
        return min(points, key=lambda p: (p[0] - x) ** 2 + (p[1] - y) ** 2)

    start, goal = nearest(0.2, 0.2), nearest(0.8, 0.75)
    return ",".join(f"{v:.2f}" for v in start), ",".join(f"{v:.2f}" for v in goal)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--server", required=True)
    here = os.path.dirname(os.path.abspath(__file__))
    parser.add_argument("--maps", default=os.path.normpath(os.path.join(here, "..", "..", "shared", "maps")))
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--screenshots", help="directory for the README's screenshots")
    args = parser.parse_args()
    missing = browser_missing()
    if missing:
        sys.exit(f"viewer_bench: {missing}")

    server = Server(args.server, ["--map-root", args.maps,
                                  "--preload", "spiral=spiral0.3_2.pcd,resolution_m=0.2",
                                  "--preload", "s20=scene20.2.pcd,resolution_m=0.2",
                                  "--preload", "site=scene:outdoor_site",
                                  "--preload", "demo=scene:two_level_ramp"])
    browser = None
    try:
        for map_id in ("spiral", "s20", "site", "demo"):
            server.wait_active(map_id, 300)
        browser = Browser(width=1280, height=800)
        for map_id, name in (("spiral", "spiral0.3_2 at 0.2 m"), ("s20", "scene20.2 at 0.2 m"),
                             ("site", "outdoor_site (100 m, 0.2 m)")):
            loads, tops, orbits = [], [], []
            for _ in range(args.runs):
                loads.append(open_map(browser, server.url, map_id))
                tops.append(frames_per_second(browser, "top"))
                orbits.append(frames_per_second(browser, "orbit"))
            first = loads[0]
            print(f"{name}: {first['surfaces']} surfaces drawn at stride {first['stride']}")
            for key, what in (("response_ms", "page received"), ("load_ms", "page loaded (load event)"),
                              ("drawn_ms", "map drawn (first frame)")):
                values = [run[key] for run in loads]
                print(f"  {what}: median {statistics.median(values):.0f} ms "
                      f"(min {min(values):.0f}, max {max(values):.0f}) after navigation start")
            print(f"  top view, panning: median {statistics.median(tops):.1f} frames/s "
                  f"(min {min(tops):.1f}, max {max(tops):.1f})")
            print(f"  3D view, orbiting: median {statistics.median(orbits):.1f} frames/s "
                  f"(min {min(orbits):.1f}, max {max(orbits):.1f})")

        if args.screenshots:
            os.makedirs(args.screenshots, exist_ok=True)
            driver = browser.driver
            open_map(browser, server.url, "spiral")
            plan(browser, SPIRAL_START, SPIRAL_GOAL)
            driver.save_screenshot(os.path.join(args.screenshots, "viewer_spiral.png"))
            driver.execute_script("document.querySelector('input[name=view][value=orbit]').click();")
            driver.execute_async_script(  # Two frames: the 3D view drawn.
                "const done = arguments[arguments.length - 1];"
                "requestAnimationFrame(() => requestAnimationFrame(done));")
            driver.save_screenshot(os.path.join(args.screenshots, "viewer_spiral_3d.png"))
            start, goal = site_query(server)
            open_map(browser, server.url, "site")
            driver.execute_script("document.getElementById('show-safety').click();")
            plan(browser, start, goal, robot="biped")
            driver.save_screenshot(os.path.join(args.screenshots, "viewer_site.png"))
            print(f"screenshots in {args.screenshots} (site plan {start} -> {goal})")
        errors = browser.console_errors()
        if errors:
            sys.exit(f"viewer_bench: console errors: {errors}")
    finally:
        if browser:
            browser.quit()
        server.stop()


if __name__ == "__main__":
    main()
