// Browser checks of the report and the replay pages (ctest label browser): headless Chromium
// (Debian's chromium) opens each page from disk through puppeteer-core (pinned in
// ../package.json) and fails on any console error, page error or failed resource.
//   node browser_check.js replay PAGE   the 3D view is drawn, the slider and the keys move
//                                       the robot and the plan drawn
//   node browser_check.js report PAGE   every image and video loads, no markdown shows as
//                                       text, every replay page linked from it loads too
// Exit status: 0 passed, 1 failed (the reasons on stderr), 77 no chromium (skipped).
'use strict';
const fs = require('fs');
const path = require('path');
const zlib = require('zlib');
const puppeteer = require('puppeteer-core');

const chromium = process.env.CHROMIUM || '/usr/bin/chromium';
const [mode, page0] = process.argv.slice(2);
if (!fs.existsSync(chromium)) {
  console.log(`browser check skipped: ${chromium} not found (Debian package chromium)`);
  process.exit(77);
}
if (!['replay', 'report'].includes(mode) || !page0 || !fs.existsSync(page0)) {
  console.error('usage: node browser_check.js replay|report PAGE (an existing .html file)');
  process.exit(2);
}

const failures = [];
function fail(what) { failures.push(what); console.error(`FAIL: ${what}`); }

async function open(browser, file) {
  const page = await browser.newPage();
  await page.setViewport({ width: 1200, height: 900 });
  const name = path.basename(file);
  page.on('console', (m) => { if (m.type() === 'error') fail(`${name}: console error: ${m.text()}`); });
  page.on('pageerror', (e) => fail(`${name}: page error: ${e.message}`));
  page.on('requestfailed', (r) => fail(`${name}: resource failed: ${r.url()} (${r.failure() && r.failure().errorText})`));
  page.on('request', (r) => {
    if (!r.url().startsWith('file:') && !r.url().startsWith('data:')) fail(`${name}: network request: ${r.url()}`);
  });
  await page.goto('file://' + path.resolve(file), { waitUntil: 'load' });
  return page;
}

async function checkReplay(browser, file) {
  const page = await open(browser, file);
  await page.waitForFunction('window.replay !== undefined', { timeout: 10000 });
  const frames = await page.evaluate('window.replay.frames');
  const geoms = await page.evaluate('[window.replay.geoms, window.replay.drawnGeoms]');
  if (geoms[0] === 0 || geoms[1] !== geoms[0]) fail(`${file}: ${geoms[1]} of the model's ${geoms[0]} geoms drawn`);
  const stats = await page.evaluate('window.replay.canvasStats()');
  const pixels = (stats.width * stats.height) / 7;
  if (stats.nonBackground < 0.02 * pixels || stats.colours < 20) {
    fail(`${file}: the 3D view looks blank (${stats.nonBackground} of ${Math.round(pixels)} sampled pixels not background, ${stats.colours} colours)`);
  }
  const canvas = await page.$('#view canvas');
  const shot = async () => Buffer.from(await canvas.screenshot());
  const state = () => page.evaluate(() => ({
    frame: window.replay.frame, status: document.getElementById('status').textContent,
  }));
  const first = await shot();
  const s0 = await state();
  // ROLLSTEP_SHOTS=DIR: the two screenshots kept, to look at.
  if (process.env.ROLLSTEP_SHOTS) fs.writeFileSync(path.join(process.env.ROLLSTEP_SHOTS, `${path.basename(file)}.first.png`), first);
  // The slider to the end, as a user drags it.
  await page.evaluate(() => {
    const s = document.getElementById('slider');
    s.value = s.max;
    s.dispatchEvent(new Event('input'));
  });
  const last = await shot();
  const s1 = await state();
  if (process.env.ROLLSTEP_SHOTS) fs.writeFileSync(path.join(process.env.ROLLSTEP_SHOTS, `${path.basename(file)}.last.png`), last);
  // A perception run's terrain in use changes with the slider too.
  if (await page.evaluate('window.replay.terrains') > 1) {
    const version = (t) => (t.match(/terrain version (\d+)/) || [])[1];
    if (version(s0.status) === undefined || version(s0.status) === version(s1.status)) {
      fail(`${file}: the foothold terrain in use did not change with the slider ('${s0.status}' then '${s1.status}')`);
    }
  }
  if (!/CBF-QP active barriers: \d+/.test(s1.status)) fail(`${file}: no CBF-QP active barriers shown ('${s1.status}')`);
  if (s1.frame !== frames - 1) fail(`${file}: the slider did not move the replay to its end (frame ${s1.frame} of ${frames})`);
  if (first.equals(last)) fail(`${file}: the 3D view is the same at the start and the end of the run`);
  if (await page.evaluate('window.replay.solutions') > 0 && s0.status === s1.status) {
    fail(`${file}: the MPC plan in use did not change with the slider (${s1.status})`);
  }
  // The keys: arrows step, space plays.
  await page.keyboard.press('ArrowLeft');
  if ((await state()).frame !== frames - 2) fail(`${file}: ArrowLeft did not step back one frame`);
  await page.evaluate(() => window.replay.show(0));
  await page.keyboard.press('ArrowRight');
  if ((await state()).frame !== 1) fail(`${file}: ArrowRight did not step one frame`);
  await page.keyboard.press(' ');
  const played = await page.waitForFunction('window.replay.frame > 3', { timeout: 10000 })
    .then(() => true, () => false);
  await page.keyboard.press(' ');
  if (!played) fail(`${file}: space did not play the replay (frame ${(await state()).frame})`);
  // The plans as decoded by the page are the run's plan.csv.gz (beside the page of `rollstep
  // view`; a report's replay_NAME.html: runs/NAME/).
  const planFile = [path.join(path.dirname(file), 'plan.csv.gz'),
    path.join(path.dirname(file), 'runs', path.basename(file).replace(/^replay_(.*)\.html$/, '$1'), 'plan.csv.gz')]
    .find((f) => fs.existsSync(f));
  if (planFile) {
    const lines = zlib.gunzipSync(fs.readFileSync(planFile)).toString('utf8').trim().split('\n');
    const names = lines[0].split(',');
    let worst = 0, worstAt = '';
    for (const [i, name] of names.entries()) {
      const decoded = await page.evaluate((n) => window.replay.planColumn(n), name);
      if (!decoded || decoded.length !== lines.length - 1) {
        fail(`${file}: plan column ${name}: ${decoded ? decoded.length : 'no'} rows, ${planFile} has ${lines.length - 1}`);
        continue;
      }
      for (let r = 1; r < lines.length; ++r) {
        const e = Math.abs(Number(lines[r].split(',')[i]) - decoded[r - 1]);
        if (e > worst) { worst = e; worstAt = `${name} row ${r}`; }
      }
    }
    if (worst > 5e-4 + 1e-9) fail(`${file}: the page's plans differ from ${planFile} by ${worst} (${worstAt})`);
    // The footholds drawn are those of the plan in use, at eleven times along the run: where
    // a contact's plan touches down, or its position at the first node for a stance contact
    // (their number changes from plan to plan).
    const rows = lines.slice(1).map((l) => l.split(',').map(Number));
    const col = (n) => names.indexOf(n);
    const feet = names.filter((n) => n.startsWith('foot_') && n.endsWith('_x[m]')).map((n) => col(n));
    const expected = (t) => {
      let first = -1;
      for (let r = 0; r < rows.length && rows[r][0] <= t + 1e-9; ++r) {
        if (r === 0 || rows[r][0] !== rows[r - 1][0] || rows[r][2] !== rows[r - 1][2]) first = r;
      }
      const holds = [];
      if (first < 0) return holds;
      let end = first;
      while (end < rows.length && rows[end][0] === rows[first][0] && rows[end][2] === rows[first][2]) ++end;
      feet.forEach((c, i) => {
        for (let r = first; r < end; ++r) {
          const stance = (rows[r][3] >> i) & 1, before = r > first && ((rows[r - 1][3] >> i) & 1);
          if (stance && (r === first || !before)) holds.push(rows[r].slice(c, c + 3));
        }
      });
      return holds;
    };
    for (let k = 0; k <= 10; ++k) {
      const f = Math.round((k * (frames - 1)) / 10);
      await page.evaluate((k) => window.replay.show(k), f);
      const drawn = await page.evaluate(() => window.replay.footholdsDrawn());
      const want = expected(await page.evaluate('window.replay.time'));
      const same = drawn.length === want.length && drawn.every((p, k) => p.every((v, a) => Math.abs(v - want[k][a]) < 1e-3));
      if (!same) fail(`${file}: frame ${f}: footholds drawn ${JSON.stringify(drawn)}, the plan in use has ${JSON.stringify(want)}`);
    }
    console.log(`${path.basename(file)}: the page's plans equal ${path.basename(planFile)}'s ${lines.length - 1} rows (worst difference ${worst.toFixed(6)} m or s)`);
  } else if (await page.evaluate('window.replay.solutions') > 0) {
    fail(`${file}: the page has MPC plans but the run's plan.csv.gz was not found to compare them with`);
  }
  const legend = await page.$eval('#legend', (e) => e.innerText);
  for (const word of ['contact force', 'base path', 'foot paths', 'footholds', 'foothold regions', 'active CBF-QP barrier']) {
    if (!legend.includes(word)) fail(`${file}: the legend does not say what '${word}' looks like`);
  }
  // A perception run's elevation map: drawn from its map log, or the page says it was not logged.
  const maps = await page.evaluate('window.replay.maps');
  if (maps > 0 && !legend.includes('elevation map (perception')) fail(`${file}: the legend does not explain the elevation map`);
  if (maps === 0 && await page.evaluate('window.replay.terrains') > 0 && !legend.includes('elevation map: not logged')) {
    fail(`${file}: a perception run without a map log, and the page does not say the map was not logged`);
  }
  // The plots' legends: the values at the slider's time (the log's time at the last frame).
  await page.evaluate((k) => window.replay.show(k), frames - 1);
  const legendTime = await page.$eval('.uplot .u-legend .u-series .u-value', (e) => e.textContent);
  const lastTime = await page.evaluate('window.replay.time');
  if (!(Math.abs(Number(legendTime) - lastTime) <= 1e-6)) fail(`${file}: the plot legend gives t = '${legendTime}' at the slider's time ${lastTime}`);
  const plots = await page.$$eval('.uplot', (e) => e.length);
  if (plots < 2) fail(`${file}: ${plots} plots, expected the linked plots`);
  console.log(`${path.basename(file)}: ${await page.evaluate('window.replay.robotFile')}, ${geoms[1]} geoms drawn, ${frames} frames, ${stats.colours} colours, plan solutions ${await page.evaluate('window.replay.solutions')}`);
  await page.close();
}

async function checkReport(browser, file) {
  const page = await open(browser, file);
  const images = await page.$$eval('img', (l) => l.map((i) => ({ src: i.getAttribute('src'), ok: i.complete && i.naturalWidth > 0 })));
  for (const i of images) if (!i.ok) fail(`${file}: image ${i.src} did not load`);
  const videos = await page.$$eval('video', (l) => l.map((v) => v.currentSrc || v.querySelector('source')?.src));
  for (const src of videos) {
    const ok = await page.evaluate((s) => new Promise((resolve) => {
      const v = document.createElement('video');
      v.onloadedmetadata = () => resolve(v.videoWidth > 0);
      v.onerror = () => resolve(false);
      v.src = s;
      setTimeout(() => resolve(false), 10000);
    }), src);
    if (!ok) fail(`${file}: video ${src} did not load`);
  }
  // Markdown syntax shown as text: emphasis, headings, table rules, links, code marks.
  const text = await page.evaluate(() => {
    const clone = document.body.cloneNode(true);
    clone.querySelectorAll('pre, code').forEach((e) => e.remove());
    return clone.innerText;
  });
  const syntax = [[/\*\*[^*\n]+\*\*/, 'bold'], [/^#{1,6} /m, 'heading'], [/\|\s*-{3,}/, 'table rule'],
    [/\]\([^)]*\)/, 'link'], [/`[^`\n]+`/, 'code span'], [/^\s*\|.*\|\s*$/m, 'table row']];
  for (const [re, what] of syntax) {
    const m = text.match(re);
    if (m) fail(`${file}: markdown ${what} shown as text: '${m[0]}'`);
  }
  const strong = await page.$$eval('strong', (l) => l.map((e) => e.textContent));
  const replays = await page.$$eval('a[href$=".html"]', (l) => l.map((a) => a.getAttribute('href')));
  console.log(`${path.basename(file)}: ${images.length} images, ${videos.length} videos, ${strong.length} bold, ${replays.length} replay links`);
  await page.close();
  if (replays.length === 0) fail(`${file}: no replay page linked`);
  for (const r of replays) {
    const target = path.resolve(path.dirname(file), r);
    if (!fs.existsSync(target)) fail(`${file}: linked replay page ${r} is missing`);
    else await checkReplay(browser, target);
  }
}

(async () => {
  const browser = await puppeteer.launch({
    executablePath: chromium,
    headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
      '--allow-file-access-from-files'],
  });
  try {
    if (mode === 'replay') await checkReplay(browser, page0);
    else await checkReport(browser, page0);
  } catch (e) {
    fail(`${page0}: ${e.stack || e}`);
  } finally {
    await browser.close();
  }
  if (failures.length) {
    console.error(`browser check failed: ${failures.length} problem(s)`);
    process.exit(1);
  }
  console.log('browser check passed');
})();
