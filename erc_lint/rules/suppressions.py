"""Rules on the suppression comments themselves (``// erc-lint:ignore RULE reason``): one that
cannot be honoured, and one that silences nothing, are findings, as ruff reports an unused
``# noqa``: a stale suppression would hide the next real break at that place."""

from .._model import Revision
from .._pairing import Change
from .._suggest import did_you_mean
from .._suppressions import suppressions
from ._registry import RULES, Found, Report, Reports, findings_rule, select, tree_rule


@tree_rule(
    "SUPPRESSION_INVALID",
    "An erc-lint:ignore comment names no rule, names an unknown one, or gives no reason.",
)
def suppression_invalid(revision: Revision, change: Change) -> Reports:
    """## What it does
    Reports an `// erc-lint:ignore` comment that silences nothing because it is malformed: it
    names no rule, names one erc-lint does not have (with the closest rule ID), or gives no
    reason after the rule IDs.

    ## Why is this bad?
    A suppression is a decision that a break is acceptable; the reason is what a reviewer (and
    the next engineer) reads to agree. A typo in a rule ID silences nothing and would leave the
    team believing the break was accepted.

    ## Example
    Before:
    ```proto
    message Status { float voltage = 1; }
    ```
    After:
    ```proto
    message Status {
      // erc-lint:ignore FIELD_DELETD
      float voltage = 1;
    }
    ```

    ## Use instead
    `// erc-lint:ignore FIELD_NUMBER_REUSED every board runs firmware 2.4, which sends current`
    on the element's line or the line above it.
    """
    for given in suppressions(revision.tree.texts, str(revision.root)):
        unknown = [rule for rule in given.rules if rule not in RULES]
        if not given.rules:
            problem = "names no rule ID"
        elif unknown:
            problem = f"names no rule {unknown[0]!r}{did_you_mean(unknown[0], RULES)}"
        elif not given.reason:
            problem = "gives no reason after the rule IDs"
        else:
            continue
        yield Report(
            given.location,
            f"Suppression {problem}, so it silences nothing.",
            key=f"{revision.place(given.location)[0]}:{','.join(given.rules)}",
            fix="write // erc-lint:ignore RULE why the break is acceptable",
        )


@findings_rule(
    "SUPPRESSION_UNUSED",
    "An erc-lint:ignore comment silences no finding (the break it accepted is gone).",
    severity="warning",
)
def suppression_unused(found: Found, change: Change) -> Reports:
    """## What it does
    Reports an `// erc-lint:ignore RULE reason` comment, valid in itself, that covered no finding
    of the rules it names in this run: the break it accepted is gone, or it sits on the wrong
    line (it covers its own line when it ends one, else the next line that is not a comment).

    ## Why is this bad?
    A stale suppression waits for the next break of that rule at that place and hides it: a
    number reused again there would pass in silence.

    ## Example
    Before:
    ```proto
    message Status { float current = 1; }
    ```
    After:
    ```proto
    message Status {
      float current = 1;  // erc-lint:ignore FIELD_TYPE_CHANGED boards updated in March
    }
    ```

    ## Use instead
    Delete the comment once it silences nothing; keep suppressions on the element they accept.
    """
    selected = select(change.config, change.has_services)
    compared = bool(change.old.tree.texts)  # `check` runs no rule on pairs
    for given in found.suppressions:
        ran = all(
            r in selected and (compared or RULES[r].pairs in ("tree", "findings"))
            for r in given.rules
        )
        if given.reason and given not in found.used and ran:
            yield Report(
                given.location,
                f"Suppression of {', '.join(given.rules)} silences no finding.",
                fix="delete the comment",
            )
