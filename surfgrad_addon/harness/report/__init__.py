"""The report page's parts (harness/report_page.py writes the page)."""
