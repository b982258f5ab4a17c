// The page in a browser, driven headless (test/web_browser.sh):
//   node web/test/browser_check.mjs URL CAMERA SIM_TIME OUT_DIR
// opens URL, waits for the scene and for a frame at least as new as SIM_TIME (XPERSim is paused there), lets the
// camera views render it, then writes OUT_DIR/CAMERA.png (the page's view through the scene camera CAMERA, at the
// camera's own pixels), OUT_DIR/page.png (the whole page, for people) and OUT_DIR/page.json (what the page shows:
// the experiment number in the progress panel, frames, latency). Exit 1 with a sentence when something is missing.
// BROWSER=chromium (the default): Debian's chromium, headless, through playwright-core. BROWSER=firefox: Debian's
// firefox-esr through puppeteer-core over WebDriver BiDi (stock Firefox speaks it; playwright needs a patched
// Firefox that cannot be had here), in a window on $DISPLAY (Xvfb), since headless Firefox offers no WebGL.
import { writeFileSync } from 'node:fs';

const [url, camera, simTimeText, out] = process.argv.slice(2);
if (!url || !camera || !simTimeText || !out) {
  console.error('usage: [BROWSER=chromium|firefox] node browser_check.mjs URL CAMERA SIM_TIME OUT_DIR');
  process.exit(2);
}
const simTime = Number(simTimeText);
const which = process.env.BROWSER || 'chromium';
const viewport = { width: 1400, height: 900 };

// The two drivers differ in how they launch and in waitForFunction's argument order; the rest is the same API.
async function open() {
  if (which === 'chromium') {
    const { chromium } = await import('playwright-core');
    const browser = await chromium.launch({
      executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
      headless: true,
      // playwright gives every launch a fresh, temporary profile (its own --user-data-dir).
      args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
             '--disable-background-networking', '--disable-component-update', '--disable-sync'],
    });
    const page = await browser.newPage({ viewport });
    return { browser, page, waitFor: (fn, arg, options) => page.waitForFunction(fn, arg, options) };
  }
  if (which === 'firefox') {
    const puppeteer = (await import('puppeteer-core')).default;
    const browser = await puppeteer.launch({
      browser: 'firefox',
      executablePath: process.env.FIREFOX || '/usr/bin/firefox-esr',
      headless: false,
      defaultViewport: viewport,
      // A closed network: no updates, telemetry or remote settings (puppeteer's profile turns most off already).
      extraPrefsFirefox: { 'app.update.enabled': false, 'network.captive-portal-service.enabled': false },
    });
    const page = await browser.newPage();
    return { browser, page, waitFor: (fn, arg, options) => page.waitForFunction(fn, options, arg) };
  }
  console.error(`BROWSER is '${which}'; it must be chromium or firefox`);
  process.exit(2);
}

const { browser, page, waitFor } = await open();
let status = 0;
try {
  const logs = [];
  page.on('console', (m) => logs.push(`${m.type()}: ${m.text()}`));
  page.on('pageerror', (e) => logs.push(`page error: ${e.message}`));
  await page.goto(url, { waitUntil: 'load', timeout: 30000 });
  try {
    await waitFor((t) => {
      const s = window.xpersif;
      return s && s.scene && s.lastFrame && s.lastFrame.simTime >= t - 1e-6;
    }, simTime, { timeout: 60000, polling: 100 });
  } catch (e) {
    const s = await page.evaluate(() => ({ scene: !!(window.xpersif && window.xpersif.scene),
      frames: window.xpersif && window.xpersif.frames, last: window.xpersif && window.xpersif.lastFrame }));
    console.error(`FAIL: the page did not show the paused frame (t = ${simTime}) within 60 s: ${JSON.stringify(s)}`);
    console.error(logs.join('\n'));
    throw e;
  }
  // Some more renders after the frame: the camera views render every third animation frame.
  const rendered = await page.evaluate(() => window.xpersif.rendered);
  await waitFor((r) => window.xpersif.rendered >= r + 12, rendered, { timeout: 30000, polling: 100 });
  // The experiment number reaches the panel with the loop's progress (latched): give it a moment.
  await waitFor(() => document.getElementById('experiment-number').dataset.experiment !== '',
    null, { timeout: 20000, polling: 100 }).catch(() => {});
  const shot = await page.evaluate((name) => {
    const c = document.getElementById('camera-' + name);
    return c ? { data: c.toDataURL('image/png'), width: c.width, height: c.height } : null;
  }, camera);
  if (!shot) {
    console.error(`FAIL: the page has no view of camera '${camera}'`);
    status = 1;
  } else {
    writeFileSync(`${out}/${camera}.png`, Buffer.from(shot.data.split(',')[1], 'base64'));
  }
  await page.screenshot({ path: `${out}/page.png` });
  const shown = await page.evaluate(() => ({
    experiment: document.getElementById('experiment-number').dataset.experiment,
    experiment_text: document.getElementById('experiment-number').textContent,
    loop_state: document.getElementById('loop-state').textContent,
    frames: window.xpersif.frames,
    frame: window.xpersif.lastFrame,
    latency_p50_ms: (() => {
      const l = [...window.xpersif.latencies].sort((a, b) => a - b);
      return l.length ? 1000 * l[Math.floor(l.length / 2)] : null;
    })(),
    cameras: [...document.querySelectorAll('#cameras canvas')].map((c) => `${c.dataset.camera} ${c.width}x${c.height}`),
    notions: window.xpersif.notions.length,
    curve_points: window.xpersif.curve.length,
  }));
  shown.logs = logs;
  writeFileSync(`${out}/page.json`, JSON.stringify(shown, null, 1));
  console.log(`${which}: camera views ${shown.cameras.join(', ')}; progress panel: experiment ${shown.experiment_text}, ` +
    `loop ${shown.loop_state}; ${shown.frames} frames, last at t = ${shown.frame.simTime.toFixed(3)} s`);
  for (const l of logs) if (/error/i.test(l)) console.log(l);
} catch (e) {
  console.error(`FAIL: ${e.message}`);
  status = 1;
} finally {
  await browser.close();
}
process.exit(status);
