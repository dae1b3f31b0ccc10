"""What JupyterLab 4 shows of an HTML output in a notebook that is not trusted (executed by
nbconvert or papermill, received, checked out from git): its sanitizer (``@jupyterlab/apputils``,
sanitize-html) removes ``<style>`` and ``<script>`` elements, every attribute not allowed for its
tag, and from each ``style`` attribute every property it does not list. The lists below are
JupyterLab 4's, for the tags and properties the package's cards could use.

:func:`sanitized` returns the HTML as JupyterLab keeps it and what it removed, so that a test
finds a card that relies on anything removed.
"""
from __future__ import annotations

from html import escape
from html.parser import HTMLParser

#: Attributes kept on every tag, and per tag (JupyterLab 4's allowedAttributes, in part).
GLOBAL = {"class", "data-jupyter-id", "dir", "draggable", "hidden", "id", "inert", "itemprop", "itemref",
          "itemscope", "lang", "spellcheck", "style", "title", "translate"}
BY_TAG = {"a": {"accesskey", "coords", "href", "hreflang", "rel", "shape", "tabindex", "target", "type"},
          "div": {"align"}, "p": {"align"}, "details": {"open"}, "li": {"type", "value"},
          "img": {"align", "alt", "border", "height", "hspace", "ismap", "src", "usemap", "vspace", "width"},
          "table": {"align", "bgcolor", "border", "cellpadding", "cellspacing", "frame", "rules", "summary", "width"},
          "tbody": {"align", "char", "charoff", "valign"}, "thead": {"align", "char", "charoff", "valign"},
          "tr": {"align", "bgcolor", "char", "charoff", "valign"},
          "td": {"abbr", "align", "axis", "bgcolor", "char", "charoff", "colspan", "headers", "height", "nowrap",
                 "rowspan", "scope", "valign", "width"},
          "th": {"abbr", "align", "axis", "bgcolor", "char", "charoff", "colspan", "headers", "height", "nowrap",
                 "rowspan", "scope", "valign", "width"}}
#: Elements removed with their content.
REMOVED = {"style", "script"}
#: Style properties kept (JupyterLab 4's allowedStyles["*"]).
PROPERTIES = set("""
backface-visibility background background-attachment background-clip background-color background-image
background-origin background-position background-repeat background-size border border-bottom border-bottom-color
border-bottom-left-radius border-bottom-right-radius border-bottom-style border-bottom-width border-collapse
border-color border-left border-left-color border-left-style border-left-width border-radius border-right
border-right-color border-right-style border-right-width border-spacing border-style border-top border-top-color
border-top-left-radius border-top-right-radius border-top-style border-top-width border-width bottom box box-shadow
box-sizing caption-side clear clip color cursor direction display display-inside display-outside elevation
empty-cells float font font-family font-size font-stretch font-style font-variant font-weight height left
letter-spacing line-height list-style list-style-image list-style-position list-style-type margin margin-bottom
margin-left margin-right margin-top max-height max-width min-height min-width opacity outline outline-color
outline-style outline-width overflow overflow-wrap overflow-x overflow-y padding padding-bottom padding-left
padding-right padding-top page-break-after page-break-before page-break-inside pause-after perspective pitch
pitch-range position quotes resize richness right speak speak-header speak-numeral speak-punctuation speech-rate
stress table-layout text-align text-decoration text-indent text-overflow text-shadow text-transform text-wrap top
unicode-bidi vertical-align visibility volume white-space width word-break word-spacing word-wrap z-index zoom
align-content align-items align-self flex flex-basis flex-direction flex-grow flex-shrink flex-wrap grid grid-area
grid-auto-columns grid-auto-flow grid-auto-rows grid-column grid-column-end grid-column-gap grid-column-start
grid-gap grid-row grid-row-end grid-row-gap grid-row-start grid-template grid-template-areas grid-template-columns
grid-template-rows gap row-gap column-gap justify-content justify-items justify-self order place-content
place-items place-self""".split())
#: Tags without an end tag.
VOID = {"img", "br", "hr", "meta", "input"}


class _Sanitizer(HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=False)
        self.out, self.removed, self.skipping = [], [], 0

    def handle_starttag(self, tag, attrs):
        if tag in REMOVED:
            self.skipping += 1
            self.removed.append(f"<{tag}>")
            return
        if self.skipping:
            return
        kept = []
        for name, value in attrs:
            if name not in GLOBAL and name not in BY_TAG.get(tag, ()):
                self.removed.append(f"{tag}[{name}]")
                continue
            if name == "style":
                parts = [p.strip() for p in (value or "").split(";") if p.strip()]
                ok = [p for p in parts if p.split(":", 1)[0].strip().lower() in PROPERTIES]
                self.removed += [f"{tag} style {p}" for p in parts if p not in ok]
                value = ";".join(ok)
            kept.append(f' {name}="{escape(value or "", quote=True)}"')
        self.out.append(f"<{tag}{''.join(kept)}>")

    def handle_endtag(self, tag):
        if tag in REMOVED:
            self.skipping -= 1
        elif not self.skipping and tag not in VOID:
            self.out.append(f"</{tag}>")

    def handle_data(self, data):
        if not self.skipping:
            self.out.append(data)

    def handle_entityref(self, name):
        if not self.skipping:
            self.out.append(f"&{name};")

    def handle_charref(self, name):
        if not self.skipping:
            self.out.append(f"&#{name};")


def sanitized(html):
    """(the HTML JupyterLab keeps of ``html`` in an untrusted notebook, [what it removed])."""
    parser = _Sanitizer()
    parser.feed(html)
    parser.close()
    return "".join(parser.out), parser.removed
