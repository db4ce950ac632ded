// A list's rows updated in place: a row a person may be using (a slider being dragged, a field being
// typed in, a row under the pointer) stays the same element when the list is shown again, so a new
// session or rest values measured by the service arriving mid-drag do not take the slider from
// under the pointer. A row whose markup is unchanged is left alone; one whose markup changed has its
// attributes and text brought to the new markup, element by element; only a row (or a part of it)
// whose elements differ in kind or number is made again. Rows are matched by a key (an edit's kind
// and name); rows gone from the list leave it, new ones come in at their place.

/** The markup each row was last made or brought to (unchanged markup: nothing to do). */
const shownAs = new WeakMap();

/** Bring `el`'s attributes to those of `fresh`. */
function attributes(el, fresh) {
  for (const { name } of [...el.attributes]) if (!fresh.hasAttribute(name)) el.removeAttribute(name);
  for (const { name, value } of fresh.attributes) if (el.getAttribute(name) !== value) el.setAttribute(name, value);
}

/** Bring node `el` to `fresh` in place where their elements match; return the node now in the DOM. */
function patch(el, fresh) {
  if (el.nodeType !== fresh.nodeType || el.nodeName !== fresh.nodeName) { el.replaceWith(fresh); return fresh; }
  if (el.nodeType !== Node.ELEMENT_NODE) {
    if (el.nodeValue !== fresh.nodeValue) el.nodeValue = fresh.nodeValue;
    return el;
  }
  attributes(el, fresh);
  const mine = [...el.childNodes], theirs = [...fresh.childNodes];
  if (mine.length !== theirs.length) el.replaceChildren(...theirs);
  else mine.forEach((c, k) => patch(c, theirs[k]));
  return el;
}

/**
 * Show `html` (the rows' markup, one top element each) in `list`, keeping the rows it has.
 * @param {HTMLElement} list
 * @param {string} html
 * @param {(row: Element) => string} keyOf which row is which (the same key: the same row)
 */
export function updateRows(list, html, keyOf) {
  const t = document.createElement("template");
  t.innerHTML = html;
  const old = new Map([...list.children].map((el) => [keyOf(el), el]));
  let k = 0;
  for (const fresh of [...t.content.children]) {
    const key = keyOf(fresh), markup = fresh.outerHTML, was = old.get(key);
    let row = fresh;
    if (was && was.nodeName === fresh.nodeName) {
      old.delete(key);
      row = was;
      if (shownAs.get(was) !== markup) patch(was, fresh);
    }
    shownAs.set(row, markup);
    const at = list.children[k];
    if (at !== row) list.insertBefore(row, at || null);
    k++;
  }
  for (const el of old.values()) el.remove();
}
