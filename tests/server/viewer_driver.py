"""A real strata-server with its web viewer, and Debian's headless Chromium driven by Selenium:
what tests/server/viewer_browser_test.py and bench/viewer_bench.py share. Run with Debian's
/usr/bin/python3 (python3-selenium; chromium and chromium-driver from
scripts/install-test-tools.sh)."""

import json
import os
import re
import shutil
import subprocess
import tempfile
import threading
import time
import urllib.error
import urllib.request

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"

# Flags for Chromium here: as root it needs --no-sandbox; on a closed network the background
# services (updates, sync, safe browsing) would keep trying connections it refuses.
CHROMIUM_FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--enable-unsafe-swiftshader",  # WebGL on the CPU (no GPU here), without a warning.
]


def browser_missing():
    """Why the browser cannot run here, or None."""
    try:
        import selenium  # noqa: F401  (only whether it is installed)
    except ImportError:
        return "python3-selenium is not installed (scripts/install-test-tools.sh installs it)"
    for path, package in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not os.access(path, os.X_OK):
            return f"{path} is missing (apt package {package}; scripts/install-test-tools.sh)"
    return None


class Server:
    """strata-server on 127.0.0.1 with ephemeral ports and the viewer on, its log collected."""

    def __init__(self, binary, args, timeout_s=60):
        self.log = []
        self.process = subprocess.Popen(
            [binary, "--listen", "127.0.0.1:0", "--metrics-port", "-1", "--http-port", "0",
             "--http-address", "127.0.0.1", *args],
            stderr=subprocess.PIPE, text=True)
        self.address = None
        self.http_port = None
        ready = threading.Event()

        def read():
            for line in self.process.stderr:
                self.log.append(line)
                match = re.search(r"address=([0-9.]+:[0-9]+) .*http_port=([0-9]+)", line)
                if match and not ready.is_set():
                    self.address, self.http_port = match.group(1), int(match.group(2))
                    ready.set()
            ready.set()

        threading.Thread(target=read, daemon=True).start()
        if not ready.wait(timeout_s) or self.http_port is None:
            self.stop()
            raise RuntimeError("strata-server did not start:\n" + "".join(self.log))
        self.url = f"http://127.0.0.1:{self.http_port}/"

    def call(self, method, request):
        """A JSON API call; the response message as a dict (raises on an HTTP error)."""
        data = json.dumps(request).encode()
        req = urllib.request.Request(self.url + "api/" + method, data=data,
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=60) as response:
            return json.load(response)

    def wait_active(self, map_id, timeout_s):
        """Waits until `map_id` is ACTIVE; raises when it fails or the time passes."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                state = self.call("strata.v1.MapService/GetMap", {"map_id": map_id})["state"]
            except urllib.error.HTTPError:
                state = "missing"
            if state == "MAP_STATE_ACTIVE":
                return
            if state == "MAP_STATE_FAILED":
                raise RuntimeError(f"map {map_id} failed:\n" + "".join(self.log))
            time.sleep(0.2)
        raise RuntimeError(f"map {map_id} not ACTIVE after {timeout_s} s")

    def stop(self):
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


class Browser:
    """Headless Chromium with a fresh profile, its console collected."""

    def __init__(self, width=1400, height=900):
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service

        self.profile = tempfile.mkdtemp(prefix="strata-chromium-")
        options = webdriver.ChromeOptions()
        options.binary_location = CHROMIUM
        for flag in CHROMIUM_FLAGS:
            options.add_argument(flag)
        options.add_argument(f"--user-data-dir={self.profile}")
        options.add_argument(f"--window-size={width},{height}")
        options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
        self.driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
        self.driver.set_script_timeout(120)

    def console_errors(self):
        """The console's SEVERE entries since the last call."""
        return [e for e in self.driver.get_log("browser") if e["level"] == "SEVERE"]

    def wait(self, condition_js, timeout_s, what):
        """Waits until `condition_js` (an expression) is truthy; returns its value."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            value = self.driver.execute_script(f"return ({condition_js});")
            if value:
                return value
            time.sleep(0.05)
        raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")

    def plan(self, start, goal, budget_s, robot=None):
        """Fills the page's plan form (robot when given, start, goal, time budget), plans,
        and waits for the plan's figures or its error."""
        if robot:
            self.driver.find_element("css selector", f"#robot option[value={robot}]").click()
        for field, value in (("start", start), ("goal", goal), ("budget", str(budget_s))):
            box = self.driver.find_element("id", field)
            box.clear()
            box.send_keys(value)
        # The last plan's result is marked first: editing start or goal redraws the map without
        # its trajectory but leaves its figures, which a wait returning before the click is
        # handled took for this plan's (0 trajectory segments, once in a fresh CI run).
        self.driver.execute_script(
            "for (const e of document.querySelectorAll('#plan-figures, #plan-error')) e.dataset.stale = '1';")
        self.driver.find_element("id", "plan").click()
        self.wait("document.querySelector('#plan-figures:not([data-stale]), #plan-error:not([data-stale])')",
                  120, "the plan's result")

    def quit(self):
        self.driver.quit()
        shutil.rmtree(self.profile, ignore_errors=True)
