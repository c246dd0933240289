// report.html's zoom and hover layer, written inline into the page (no network, no other file).
// It works on the figures' own SVG: plot.rs puts each panel's curves in a `g.kd-panel` group
// whose data-* attributes give the pixel position of the axes' ends and their data values, and
// each curve in a `g.kd-series` group with its label. Hover turns the nearest drawn point of
// the nearest curve back into data values; zoom changes the figure's viewBox.
//
// Wheel over a figure: zoom in or out about the pointer. Drag a box: zoom into it.
// Double-click: back to the whole figure. `#selftest` in the address runs a scripted wheel,
// hover, drag and double-click on the first figure and writes what happened into
// a `pre` element of id kd-selftest at the end of the body (the tests read it through
// headless Chromium's --dump-dom).
(function () {
  'use strict';
  var NS = 'http://www.w3.org/2000/svg';
  var tip = document.createElement('div');
  tip.className = 'kd-tip';
  tip.hidden = true;
  document.body.appendChild(tip);

  function nums(el, name) {
    return (el.getAttribute(name) || '').split(' ').map(Number);
  }
  // Five significant digits, exponent form only for very large or small values.
  function fmt(v) {
    var a = Math.abs(v);
    if (v === 0) return '0';
    return a >= 1e-3 && a < 1e5 ? String(Number(v.toPrecision(5))) : v.toExponential(4);
  }
  function view(svg) {
    var b = svg.viewBox.baseVal;
    return [b.x, b.y, b.width, b.height];
  }
  function setView(svg, b) {
    svg.setAttribute('viewBox', b.map(function (v) { return Number(v.toFixed(3)); }).join(' '));
  }
  // Client (window) pixels to the SVG's user units and back.
  function toSvg(svg, cx, cy) {
    var p = svg.createSVGPoint();
    p.x = cx;
    p.y = cy;
    return p.matrixTransform(svg.getScreenCTM().inverse());
  }
  function toClient(svg, x, y) {
    var p = svg.createSVGPoint();
    p.x = x;
    p.y = y;
    return p.matrixTransform(svg.getScreenCTM());
  }
  // SVG user units per client pixel at the current zoom.
  function unit(svg) {
    var r = svg.getBoundingClientRect();
    return r.width > 0 ? view(svg)[2] / r.width : 1;
  }

  // The panels of a figure with their curves' drawn points (pixel positions).
  function panels(svg) {
    return Array.prototype.map.call(svg.querySelectorAll('g.kd-panel'), function (g) {
      var p = {
        px: nums(g, 'data-px'), py: nums(g, 'data-py'), x: nums(g, 'data-x'), y: nums(g, 'data-y'),
        log: g.getAttribute('data-log-y') === '1',
        xl: g.getAttribute('data-x-label'), yl: g.getAttribute('data-y-label'), series: []
      };
      Array.prototype.forEach.call(g.querySelectorAll('g.kd-series'), function (s) {
        var pts = [];
        Array.prototype.forEach.call(s.querySelectorAll('polyline'), function (l) {
          for (var i = 0; i < l.points.numberOfItems; i++) {
            var q = l.points.getItem(i);
            pts.push([q.x, q.y]);
          }
        });
        Array.prototype.forEach.call(s.querySelectorAll('circle'), function (c) {
          pts.push([c.cx.baseVal.value, c.cy.baseVal.value]);
        });
        p.series.push({ label: s.getAttribute('data-label') || '', points: pts });
      });
      return p;
    });
  }
  function inside(p, x, y) {
    return x >= Math.min(p.px[0], p.px[1]) && x <= Math.max(p.px[0], p.px[1]) &&
      y >= Math.min(p.py[0], p.py[1]) && y <= Math.max(p.py[0], p.py[1]);
  }
  // A drawn point's data values: the axes' mapping inverted (logarithmic in y when the panel is).
  function data(p, x, y) {
    var tx = (x - p.px[0]) / (p.px[1] - p.px[0]);
    var ty = (y - p.py[0]) / (p.py[1] - p.py[0]);
    return [
      p.x[0] + tx * (p.x[1] - p.x[0]),
      p.log ? p.y[0] * Math.pow(p.y[1] / p.y[0], ty) : p.y[0] + ty * (p.y[1] - p.y[0])
    ];
  }
  // The drawn point nearest to (x, y) within `reach` user units, over the panel's curves.
  function nearest(p, x, y, reach) {
    var best = null, d2 = reach * reach;
    p.series.forEach(function (s) {
      s.points.forEach(function (q) {
        var d = (q[0] - x) * (q[0] - x) + (q[1] - y) * (q[1] - y);
        if (d <= d2) {
          d2 = d;
          best = { series: s, at: q };
        }
      });
    });
    return best;
  }

  function attach(svg) {
    var start = view(svg);
    var figure = panels(svg);
    var dot = document.createElementNS(NS, 'circle');
    dot.setAttribute('class', 'kd-dot');
    dot.setAttribute('visibility', 'hidden');
    svg.appendChild(dot);
    var band = document.createElementNS(NS, 'rect');
    band.setAttribute('class', 'kd-band');
    band.setAttribute('visibility', 'hidden');
    svg.appendChild(band);
    var drag = null;

    function hide() {
      tip.hidden = true;
      dot.setAttribute('visibility', 'hidden');
    }
    function hover(e) {
      if (drag) return;
      var q = toSvg(svg, e.clientX, e.clientY);
      var p = figure.filter(function (p) { return inside(p, q.x, q.y); })[0];
      var hit = p && nearest(p, q.x, q.y, 25 * unit(svg));
      if (!hit) return hide();
      var v = data(p, hit.at[0], hit.at[1]);
      tip.textContent = (hit.series.label ? hit.series.label + '\n' : '') +
        p.xl + ' = ' + fmt(v[0]) + '\n' + p.yl + ' = ' + fmt(v[1]);
      tip.style.left = (e.clientX + 14) + 'px';
      tip.style.top = (e.clientY + 14) + 'px';
      tip.hidden = false;
      dot.setAttribute('cx', hit.at[0]);
      dot.setAttribute('cy', hit.at[1]);
      dot.setAttribute('r', 4 * unit(svg));
      dot.setAttribute('visibility', 'visible');
    }
    svg.addEventListener('mousemove', hover);
    svg.addEventListener('mouseleave', hide);
    svg.addEventListener('wheel', function (e) {
      e.preventDefault();
      hide();
      var q = toSvg(svg, e.clientX, e.clientY);
      var b = view(svg), f = e.deltaY < 0 ? 1 / 1.25 : 1.25;
      if (b[2] * f >= start[2]) return setView(svg, start);
      setView(svg, [q.x - (q.x - b[0]) * f, q.y - (q.y - b[1]) * f, b[2] * f, b[3] * f]);
    }, { passive: false });
    svg.addEventListener('mousedown', function (e) {
      if (e.button !== 0) return;
      e.preventDefault();
      hide();
      drag = toSvg(svg, e.clientX, e.clientY);
    });
    window.addEventListener('mousemove', function (e) {
      if (!drag) return;
      var q = toSvg(svg, e.clientX, e.clientY);
      band.setAttribute('x', Math.min(drag.x, q.x));
      band.setAttribute('y', Math.min(drag.y, q.y));
      band.setAttribute('width', Math.abs(q.x - drag.x));
      band.setAttribute('height', Math.abs(q.y - drag.y));
      band.setAttribute('stroke-width', unit(svg));
      band.setAttribute('visibility', 'visible');
    });
    window.addEventListener('mouseup', function (e) {
      if (!drag) return;
      var q = toSvg(svg, e.clientX, e.clientY), from = drag, u = unit(svg);
      drag = null;
      band.setAttribute('visibility', 'hidden');
      // A click or a thin sliver is not a box.
      if (Math.abs(q.x - from.x) > 5 * u && Math.abs(q.y - from.y) > 5 * u) {
        setView(svg, [Math.min(from.x, q.x), Math.min(from.y, q.y), Math.abs(q.x - from.x), Math.abs(q.y - from.y)]);
      }
    });
    svg.addEventListener('dblclick', function () {
      hide();
      setView(svg, start);
    });
    return figure;
  }

  var figures = Array.prototype.map.call(document.querySelectorAll('figure.plot svg'), function (svg) {
    return { svg: svg, panels: attach(svg) };
  });

  // The scripted check: real events through the listeners above, on the first figure that has
  // a curve; the results go into the page for the test to read.
  function selftest() {
    var out = { figures: figures.length };
    var f = figures.filter(function (f) {
      return f.panels.some(function (p) { return p.series.some(function (s) { return s.points.length > 2; }); });
    })[0];
    if (f) {
      var svg = f.svg, p = f.panels.filter(function (p) {
        return p.series.some(function (s) { return s.points.length > 2; });
      })[0];
      var s = p.series.filter(function (s) { return s.points.length > 2; })[0];
      var at = function (x, y) { return toClient(svg, x, y); };
      var mouse = function (target, type, c) {
        target.dispatchEvent(new MouseEvent(type, { clientX: c.x, clientY: c.y, bubbles: true, cancelable: true, button: 0 }));
      };
      out.figure = svg.closest('figure').id;
      out.start = svg.getAttribute('viewBox');
      var c = at((p.px[0] + p.px[1]) / 2, (p.py[0] + p.py[1]) / 2);
      svg.dispatchEvent(new WheelEvent('wheel', { deltaY: -100, clientX: c.x, clientY: c.y, bubbles: true, cancelable: true }));
      out.wheel = svg.getAttribute('viewBox');
      var q = s.points[Math.floor(s.points.length / 2)];
      mouse(svg, 'mousemove', at(q[0], q[1]));
      out.series = s.label;
      out.tip = tip.hidden ? null : tip.textContent;
      out.x_label = p.xl;
      out.y_label = p.yl;
      svg.dispatchEvent(new MouseEvent('dblclick', { bubbles: true }));
      out.reset = svg.getAttribute('viewBox');
      var lo = at(p.px[0] + 0.25 * (p.px[1] - p.px[0]), p.py[1] + 0.25 * (p.py[0] - p.py[1]));
      var hi = at(p.px[0] + 0.75 * (p.px[1] - p.px[0]), p.py[1] + 0.75 * (p.py[0] - p.py[1]));
      mouse(svg, 'mousedown', lo);
      mouse(window, 'mousemove', hi);
      mouse(window, 'mouseup', hi);
      out.drag = svg.getAttribute('viewBox');
      svg.dispatchEvent(new MouseEvent('dblclick', { bubbles: true }));
    }
    var pre = document.createElement('pre');
    pre.id = 'kd-selftest';
    pre.textContent = JSON.stringify(out);
    document.body.appendChild(pre);
  }
  if (location.hash === '#selftest') {
    window.addEventListener('load', function () { setTimeout(selftest, 0); });
  }
})();
