"""The user study kit: plan, questionnaire, statistics report and Minari export."""
