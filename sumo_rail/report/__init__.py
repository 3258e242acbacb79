"""Reading run folders and metrics files and drawing them: plots and the Markdown report.

May import: every stage before it.
"""
