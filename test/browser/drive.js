// Copyright 2026 formation_control developers
//
// Licensed under the Apache License, Version 2.0 (the "License");
// you may not use this file except in compliance with the License.
// You may obtain a copy of the License at
//
//     http://www.apache.org/licenses/LICENSE-2.0
//
// Unless required by applicable law or agreed to in writing, software
// distributed under the License is distributed on an "AS IS" BASIS,
// WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
// See the License for the specific language governing permissions and
// limitations under the License.

// Opens the host page in headless Chromium over the DevTools protocol (playwright-core) and
// prints what the app shows as JSON: whether every topic of TOPICS was listed before the timeout,
// the page's text, the text of the Problems tab, the console errors, the failed requests and
// the box (CSS pixels) of each panel titled in TITLES; writes the screenshot OUT_DIR/app.png.
// Usage: node drive.js URL CHROMIUM OUT_DIR TOPICS TITLES TIMEOUT_S  (lists: JSON arrays)

const { chromium } = require('playwright-core');

// The box of the panel whose title bar reads `title`: the title's nearest ancestor that also
// holds the panel's content (a canvas, or more text than the title).
function panelBox(title) {
  const label = [...document.querySelectorAll('*')].find(
    (el) => el.children.length === 0 && el.textContent.trim() === title);
  for (let el = label; el; el = el.parentElement) {
    const box = el.getBoundingClientRect();
    if (el.querySelector('canvas') || el.innerText.trim().length > title.length + 20) {
      return { x: box.x, y: box.y, width: box.width, height: box.height };
    }
  }
  return null;
}

async function main() {
  const [url, executablePath, out, topics, titles, timeout] = process.argv.slice(2);
  const browser = await chromium.launch({
    executablePath, headless: true,
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
           '--renderer-process-limit=1'],
  });
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  page.setDefaultTimeout(1000 * Number(timeout));
  const errors = [];
  const failed = [];
  page.on('console', (msg) => { if (msg.type() === 'error') { errors.push(msg.text()); } });
  page.on('pageerror', (err) => errors.push(String(err)));
  page.on('response', (res) => { if (res.status() >= 400) { failed.push(res.url()); } });
  await page.goto(url);
  await page.getByText('/formation_monitor').first().waitFor();   // connected: its name
  await page.getByRole('tab', { name: 'Topics' }).click();   // a passing problem shows its tab
  const listed = await page.waitForFunction(
    (names) => names.every((name) => document.body.innerText.includes(name)), JSON.parse(topics),
    { timeout: 1000 * Number(timeout), polling: 1000 }).then(() => true, () => false);
  await page.waitForTimeout(8000);                 // let the plots and the scene draw
  const panels = {};
  for (const title of JSON.parse(titles)) {
    panels[title] = await page.evaluate(panelBox, title);
  }
  await page.screenshot({ path: `${out}/app.png` });
  const text = await page.evaluate(() => document.body.innerText);
  await page.getByRole('tab', { name: 'Problems' }).click();
  await page.waitForTimeout(500);
  const problems = await page.evaluate(() => document.body.innerText);
  console.log(JSON.stringify({ listed, text, problems, errors, failed, panels }));
  await browser.close();
}

main().catch((err) => { console.error(err); process.exit(1); });
