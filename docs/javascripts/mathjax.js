// MathJax 3 for the maths of pymdownx.arithmatex (generic mode): only the elements of
// class "arithmatex" are typeset; the component itself is assets/mathjax/tex-svg-full.js,
// copied from its PyPI package at build time (docs/mathjax_hook.py).
window.MathJax = {
  tex: {
    inlineMath: [["\\(", "\\)"]],
    displayMath: [["\\[", "\\]"]],
    processEscapes: true,
    processEnvironments: true
  },
  svg: { fontCache: "global" },
  options: {
    ignoreHtmlClass: ".*|",
    processHtmlClass: "arithmatex",
    enableMenu: false
  }
};
